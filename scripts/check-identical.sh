#!/usr/bin/env bash
# Checks that two rqr builds render the same images and statistics: temporal reuse in every mode
# (rt and hybrid; reprojection, both visibility checks, adaptive sub-sampling, frameless
# rendering, max age, frame ranges, moving geometry, burst timing, EXR output, both ray
# backends) and a few single frames. For refactors that must not change what rqr computes.
#
#   scripts/check-identical.sh BEFORE AFTER
#   scripts/check-identical.sh --render BIN DIR     # only render BIN's outputs into DIR
#   scripts/check-identical.sh --models MODELS BEFORE AFTER
#   scripts/check-identical.sh --models MODELS --render BIN DIR
#
# With --models, the cases are instead every model listed in MODELS/INDEX.tsv (a tab-separated
# table whose first two columns are a name and the model file relative to MODELS, with a header
# line), each rendered once at 64x64 on both ray backends (`--backend hw` and `--backend bvh`),
# with `RQR_NO_AUTOTUNE=1` so that no measurement decides anything.
#
# BEFORE and AFTER are each an rqr binary (its outputs are rendered into a temporary folder) or
# a folder written earlier by `--render`. Images (PNG, EXR) must be byte-identical; JSON lines
# are compared after dropping what measures time (keys naming gpu, ms, timing, Mrays/s, and the
# summary's per-pass time statistics), which legitimately differs from run to run. Exit status 0 when everything matches, 1 otherwise.
# Runs on any Vulkan device; `. scripts/env.sh` first picks lavapipe.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
assets="$root/assets"
size=(--width 64 --height 64)

# name | arguments (a sequence writes NAME_NNNN.png; a single frame NAME.png)
cases=(
  "rt_reproject|--frames 6 --camera-path orbit:0.5 --reproject --sources"
  "rt_full_visibility|--frames 6 --camera-path orbit:0.5 --reproject --rt-visibility full --sources"
  "rt_adaptive|--frames 6 --camera-path orbit:0.5 --reproject --adaptive-subsample --subsample-threshold 0.2 --sources"
  "rt_adaptive_only|--frames 4 --camera-path orbit:0.5 --adaptive-subsample --sources"
  "rt_frameless|--frames 6 --camera-path orbit:0.5 --frameless 10 --sources"
  "rt_max_age|--frames 6 --camera-path dolly:0.05 --reproject --max-age 2 --sources"
  "rt_range|--frames 12 --frame-range 5..9 --camera-path orbit:0.5 --frameless 5"
  "rt_hw|--frames 4 --camera-path orbit:0.5 --reproject --backend hw --sources"
  "rt_exr|--frames 4 --camera-path orbit:0.5 --reproject --reference EXR"
  "rt_burst|--frames 6 --camera-path orbit:0.5 --reproject --reference --benchmark --burst 3"
  "hybrid_reproject|--frames 6 --camera-path orbit:0.5 --mode hybrid --reproject --sources"
  "hybrid_adaptive|--frames 6 --camera-path orbit:0.5 --mode hybrid --reproject --adaptive-subsample --subsample-threshold 0.2 --sources"
  "hybrid_frameless|--frames 6 --camera-path orbit:0.5 --mode hybrid --frameless 10 --sources"
  "moving_hybrid|SCENE=gltf/CesiumMan/CesiumMan.glb --frames 5 --fps 24 --mode hybrid --reproject --reference --sources"
  "moving_rt|SCENE=gltf/BoxAnimated/BoxAnimated.glb --frames 5 --fps 24 --reproject --sources"
  "gltf_rt|SCENE=gltf/SpecularTest/SpecularTest.glb --frames 4 --camera-path orbit:1 --reproject --adaptive-subsample --sources"
  "single_rt|ONE"
  "single_hybrid|ONE --mode hybrid"
  "single_avocado|ONE SCENE=gltf/Avocado/Avocado.gltf --mode hybrid"
)

models=""
if [ "${1:-}" = "--models" ]; then
  [ $# -ge 2 ] || { echo "usage: $0 --models MODELS BEFORE AFTER" >&2; exit 2; }
  models="$(realpath "$2")"
  shift 2
  [ -f "$models/INDEX.tsv" ] || { echo "$models/INDEX.tsv: no such file" >&2; exit 2; }
  cases=()
  while IFS=$'\t' read -r name file _; do
    case "$file" in *" "*) echo "$file: paths with spaces are not supported" >&2; exit 2 ;; esac
    for backend in hw bvh; do
      cases+=("model_${name}_$backend|ONE MODEL=$file --backend $backend")
    done
  done < <(tail -n +2 "$models/INDEX.tsv")
  export RQR_NO_AUTOTUNE=1
fi

render() {
  local bin dir
  bin="$(realpath "$1")"
  dir="$2"
  mkdir -p "$dir"
  for case in "${cases[@]}"; do
    local name="${case%%|*}" words=() scene=() out ext=png single=0
    for w in ${case#*|}; do
      case "$w" in
        SCENE=*) scene=("$assets/${w#SCENE=}") ;;
        MODEL=*) scene=("$models/${w#MODEL=}") ;;
        EXR) ext=exr ;;
        ONE) single=1 ;;
        *) words+=("$w") ;;
      esac
    done
    out="$name.$ext"
    echo "== $name: rqr render ${scene[*]} ${words[*]} ${size[*]} --json -o $out" >&2
    if ! (cd "$dir" && "$bin" render "${scene[@]}" "${words[@]}" "${size[@]}" --json -o "$out" \
      >"$name.jsonl" 2>"$name.log"); then
      echo "   failed (see $dir/$name.log)" >&2
      return 1
    fi
    [ "$single" = 1 ] || ls "$dir/${name}_"*".$ext" >/dev/null
  done
  touch "$dir/.complete"
}

# The JSON lines without what measures time (keys naming it, and the per-pass time statistics of a
# sequence's summary, of which only the pass names stay).
untimed() {
  jq -cS 'walk(if type == "object" then (if has("median") and has("name") then {name} else . end)
    | with_entries(select(.key | test("gpu|_ms$|^ms$|timing|mrays"; "i") | not)) else . end)' "$1"
}

compare() {
  local a="$1" b="$2" bad=0 n=0
  for f in "$a"/*; do
    local name="${f##*/}" g="$b/${f##*/}"
    case "$name" in *.log) continue ;; esac
    n=$((n + 1))
    if [ ! -e "$g" ]; then
      echo "missing in $b: $name"
      bad=1
    elif [[ "$name" == *.jsonl ]]; then
      if ! cmp -s <(untimed "$f") <(untimed "$g"); then
        echo "statistics differ: $name"
        diff <(untimed "$f" | jq -S .) <(untimed "$g" | jq -S .) | head -20 || true
        bad=1
      fi
    elif ! cmp -s "$f" "$g"; then
      echo "differs: $name"
      bad=1
    fi
  done
  for g in "$b"/*; do
    [ -e "$a/${g##*/}" ] || [[ "$g" == *.log ]] || { echo "missing in $a: ${g##*/}"; bad=1; }
  done
  if [ "$bad" = 0 ]; then
    echo "identical: $n files ($a vs $b)"
  fi
  return "$bad"
}

outputs_of() {
  if [ -d "$1" ]; then
    [ -e "$1/.complete" ] || { echo "$1: incomplete (no .complete)" >&2; exit 1; }
    echo "$1"
  else
    local dir
    dir="$(mktemp -d "${TMPDIR:-/tmp}/rqr-identical.XXXXXX")"
    render "$1" "$dir"
    echo "$dir"
  fi
}

if [ "${1:-}" = "--render" ]; then
  [ $# = 3 ] || { echo "usage: $0 [--models MODELS] --render BIN DIR" >&2; exit 2; }
  render "$2" "$3"
  exit 0
fi
[ $# = 2 ] || { echo "usage: $0 [--models MODELS] BEFORE AFTER (each an rqr binary or a --render folder)" >&2; exit 2; }
before="$(outputs_of "$1")"
after="$(outputs_of "$2")"
compare "$before" "$after"
