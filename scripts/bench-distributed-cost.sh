#!/usr/bin/env bash
# The cost of a 1-spp distributed frame at depth 3 against the Whitted frame, with the two
# timed alternately: ROUNDS rounds of one `rqr render --benchmark` burst per shading model, the
# ratio of their median frame GPU times per round (minutes apart, lavapipe's speed drifts more
# than the effect), and the median ratio over the rounds. Scenes: the built-in room with
# --light-radius 0.1, and DamagedHelmet under sunrise.hdr; both paths.
# usage: scripts/bench-distributed-cost.sh [HELMET.glb]   (env: SIZE=512 ROUNDS=5 BURST=5 RQR=...)
set -euo pipefail
cd "$(dirname "$0")/.."
HELMET=${1:-../shared/gltf/DamagedHelmet/DamagedHelmet.glb}
SIZE=${SIZE:-512}
ROUNDS=${ROUNDS:-5}
BURST=${BURST:-5}
RQR=${RQR:-target/debug/rqr}
[ -x "$RQR" ] || cargo build -q
. scripts/env.sh
OUT=$(mktemp -d)
frame_ms() {
  "$RQR" render "$@" --width "$SIZE" --height "$SIZE" --max-depth 3 --frames "$BURST" --benchmark \
    --burst "$BURST" --json -o "$OUT/f.png" 2>/dev/null | tail -1 |
    python3 -c 'import json,sys; print(json.load(sys.stdin)["summary"]["frame_gpu_ms"]["median"])'
}
for scene in ${SCENES:-built-in helmet}; do
  if [ $scene = built-in ]; then args=(--light-radius 0.1); else args=("$HELMET" --environment assets/environments/sunrise.hdr); fi
  for mode in ${MODES:-rt hybrid}; do
    ratios=()
    for _ in $(seq "$ROUNDS"); do
      w=$(frame_ms "${args[@]}" --mode $mode --shading whitted)
      d=$(frame_ms "${args[@]}" --mode $mode --shading distributed)
      ratios+=("$d/$w")
    done
    python3 - "$scene" "$mode" "${ratios[@]}" <<'PY'
import statistics, sys
scene, mode, *pairs = sys.argv[1:]
r = [(float(d) / float(w), float(d), float(w)) for d, w in (p.split("/") for p in pairs)]
med = statistics.median(x[0] for x in r)
print(f"{scene} {mode}: median {med:.2f}x over {len(r)} rounds; rounds " + ", ".join(f"{x[0]:.2f} ({x[1]:.0f}/{x[2]:.0f} ms)" for x in r))
PY
  done
done
rm -rf "$OUT"
