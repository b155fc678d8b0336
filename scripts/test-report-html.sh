#!/usr/bin/env bash
# Browser test of `rqr compare`'s report.html, in headless Chromium (Debian package `chromium`;
# .ci/run installs it). Renders a small compare with every backend, loads the page with a test
# script appended and checks in the browser that every image decoded (natural size > 0), that
# moving the wipe slider changes which image is shown at the centre of each viewer (hit test
# through the clip), and that the GPU-time chart has a bar per backend and path. Then takes a
# screenshot of the unmodified page (default target/report-html/report.png; look at it).
# usage: scripts/test-report-html.sh [SCREENSHOT.png]
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ensure-setup.sh
CHROMIUM=${CHROMIUM:-$(command -v chromium || command -v chromium-browser || true)}
if [ -z "$CHROMIUM" ]; then
  echo "test-report-html: FAIL: chromium not found (Debian: apt-get install chromium; or set CHROMIUM)" >&2
  exit 1
fi
shot=${1:-target/report-html/report.png}
work=target/report-html
rm -rf "$work/compare" "$work/check.html"
mkdir -p "$work" "$(dirname "$shot")"
cargo build --quiet --bin rqr
RQR_NO_AUTOTUNE=1 RQR_VALIDATION=1 target/debug/rqr compare --backends all --width 96 --height 64 --max-depth 2 \
  --repeat 1 -o "$work/compare" >/dev/null
html="$work/compare/report.html"
[ -s "$html" ] || { echo "test-report-html: FAIL: $html was not written" >&2; exit 1; }
backends=$(grep -c '"backend": "' "$work/compare/report.json")

# The page plus a test script that reports into the DOM, which --dump-dom prints.
{
  sed 's#</body></html>##' "$html"
  cat <<JS
<script>
window.addEventListener('load', () => {
  const errors = [];
  const images = [...document.images];
  for (const im of images)
    if (!(im.complete && im.naturalWidth > 0 && im.naturalHeight > 0)) errors.push('not decoded: ' + im.alt);
  const viewers = [...document.querySelectorAll('figure.wipe')];
  if (viewers.length !== $backends) errors.push(viewers.length + ' wipe viewers for $backends backends');
  for (const fig of viewers) {
    const name = fig.dataset.backend, stage = fig.querySelector('.stage');
    const over = fig.querySelector('img.over'), under = fig.querySelector('img.under');
    const slider = fig.querySelector('input.wipe-slider');
    stage.scrollIntoView({block: 'center'});
    const shown = (value) => {
      slider.value = value;
      slider.dispatchEvent(new Event('input'));
      const r = stage.getBoundingClientRect();
      return [document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2), getComputedStyle(over).clipPath];
    };
    const [atRt, clipRt] = shown(100), [atHybrid, clipHybrid] = shown(0), [atMiddle] = shown(75);
    if (atRt !== over) errors.push(name + ': slider at 100 shows ' + (atRt && atRt.alt) + ', not ray traced');
    if (atHybrid !== under) errors.push(name + ': slider at 0 shows ' + (atHybrid && atHybrid.alt) + ', not hybrid');
    if (atMiddle !== over) errors.push(name + ': slider at 75 shows ' + (atMiddle && atMiddle.alt) + ' at the centre');
    if (clipRt === clipHybrid) errors.push(name + ': clip unchanged by the slider (' + clipRt + ')');
  }
  const rows = document.querySelectorAll('svg.chart text.rowlabel').length;
  const bars = [...document.querySelectorAll('svg.chart rect.seg')].filter((r) => r.getBBox().width > 0).length;
  if (rows !== 2 * $backends) errors.push(rows + ' chart rows for $backends backends x 2 paths');
  if (bars < 2 * $backends) errors.push('only ' + bars + ' visible bar segments');
  if (document.querySelectorAll('.legend img.lut').length !== $backends) errors.push('FLIP legend missing');
  const out = document.createElement('pre');
  out.id = 'rqr-test';
  out.textContent = (errors.length ? 'RQR-TEST-FAIL ' + errors.join('; ') : 'RQR-TEST-PASS')
    + ' (images ' + images.length + ', viewers ' + viewers.length + ', chart rows ' + rows + ', bar segments ' + bars + ')';
  document.body.appendChild(out);
});
</script></body></html>
JS
} > "$work/check.html"

flags=(--headless --no-sandbox --disable-gpu --no-first-run --disable-extensions --hide-scrollbars
  --user-data-dir="$PWD/$work/profile")
dom=$(timeout 120 "$CHROMIUM" "${flags[@]}" --window-size=1400,1000 --virtual-time-budget=10000 \
  --dump-dom "file://$PWD/$work/check.html" 2>"$work/chromium.log") || true
result=$(grep -o '<pre id="rqr-test">[^<]*' <<<"$dom" | sed 's/^<pre id="rqr-test">//' || true)
if [[ "$result" != RQR-TEST-PASS* ]]; then
  echo "test-report-html: FAIL: ${result:-the page did not run its test (see $work/chromium.log)}" >&2
  exit 1
fi
timeout 120 "$CHROMIUM" "${flags[@]}" --window-size=1400,1800 --screenshot="$PWD/$shot" \
  "file://$PWD/$html" 2>>"$work/chromium.log" >/dev/null || true
[ -s "$shot" ] || { echo "test-report-html: FAIL: no screenshot (see $work/chromium.log)" >&2; exit 1; }
echo "test-report-html: ok: $result; screenshot $shot"
