#!/usr/bin/env bash
# The environment lookup's cost as instructions per frame, which repeat exactly where this
# machine's timestamps wander by ±6 %: single-threaded lavapipe (LP_NUM_THREADS=0) under
# cachegrind, per frame = (instructions of FRAMES_HI frames − of FRAMES_LO) / (HI − LO), so
# start-up, loading and pipeline compiles cancel. Prints the device's instructions for a Whitted
# frame without and with the map, for each path, and the lookup's share.
#
#   scripts/bench-lookup-instructions.sh [MAP.hdr]      # default assets/environments/studio.hdr
#   SIZE=512 PATHS="rt hybrid" RQR=path/to/rqr scripts/bench-lookup-instructions.sh
#
# Uses rqr's release build (built if missing; RQR=BINARY measures another, e.g. an older
# commit's for a before/after). Needs valgrind (Debian: valgrind).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/ensure-setup.sh
MAP="${1:-assets/environments/studio.hdr}"
SIZE="${SIZE:-128}"
PATHS="${PATHS:-rt hybrid}"
FRAMES_LO="${FRAMES_LO:-1}"
FRAMES_HI="${FRAMES_HI:-3}"
# A frame under valgrind takes minutes at 512²: far past rqr's 60 s fence timeout.
TIMEOUT_MS="${TIMEOUT_MS:-3600000}"
command -v valgrind >/dev/null || { echo "needs valgrind (apt-get install valgrind)" >&2; exit 1; }
if [ -z "${RQR:-}" ]; then
  cargo build --release --bin rqr -q
  RQR=target/release/rqr
fi
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT


# Instructions the device executed in one `rqr render` run: lavapipe runs the shaders on the
# calling thread when LP_NUM_THREADS=0, as JIT code without symbols, so the device's share is
# what cachegrind attributes to no file and no function (the host's PNG encoding, which grows
# with the frame count too, is left out). Summed as a float: mawk's %d stops at 2^31.
instructions() {
  LP_NUM_THREADS=0 valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file="$work/cg.out" \
    "$RQR" render --backend bvh --width "$SIZE" --height "$SIZE" --timeout-ms "$TIMEOUT_MS" \
    -o "$work/img.png" "$@" >/dev/null 2>&1 || { echo "rqr render $* failed under valgrind" >&2; exit 1; }
  awk '/^fl=/ { fl = substr($0, 4) } /^fn=/ { fn = substr($0, 4) }
       /^[0-9]/ && fl == "???" && fn == "???" { sum += $2 }
       END { printf "%.0f\n", sum }' "$work/cg.out"
}

per_frame() {
  local lo hi frames
  # The longer run once first, under valgrind too: Mesa's shader cache is keyed by the CPU's
  # features, which valgrind reports otherwise, and a cold compile costs billions of
  # instructions that would not cancel. rqr's environment cache fills at the same time.
  LP_NUM_THREADS=0 valgrind --tool=none "$RQR" render --backend bvh --width "$SIZE" --height "$SIZE" \
    --timeout-ms "$TIMEOUT_MS" -o "$work/img.png" --frames "$FRAMES_HI" "$@" >/dev/null 2>&1 ||
    { echo "rqr render $* failed under valgrind" >&2; exit 1; }
  lo=$(instructions --frames "$FRAMES_LO" "$@")
  hi=$(instructions --frames "$FRAMES_HI" "$@")
  echo $(((hi - lo) / (FRAMES_HI - FRAMES_LO)))
}

for path in $PATHS; do
  plain=$(per_frame --mode "$path")
  lit=$(per_frame --mode "$path" --environment "$MAP")
  awk -v p="$path" -v a="$plain" -v b="$lit" -v s="$SIZE" 'BEGIN {
    printf "%s %dx%d: %.1f M -> %.1f M instructions per frame (%+.2f %%)\n", p, s, s, a / 1e6, b / 1e6, (b / a - 1) * 100 }'
done
