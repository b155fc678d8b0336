#!/usr/bin/env bash
# Distributed shading against the Whitted model: the cost of a 1-spp distributed frame at
# depth 3 against the Whitted frame (the seed's budget: 1 shadow ray per light sample and 1
# reflection ray per bounce), and error against time (FLIP/PSNR against a converged
# distributed reference) for Whitted and distributed 1/4/16 spp on both paths, all measured in
# one `rqr compare --reference-spp` run per scene (GPU timestamps of one frame per row).
# Scenes: the built-in room with --light-radius 0.1, and DamagedHelmet under sunrise.hdr.
# usage: scripts/bench-distributed.sh [HELMET.glb]   (env: SIZE=512 REF_SPP=64 OUT=... RQR=...)
set -euo pipefail
cd "$(dirname "$0")/.."
HELMET=${1:-../shared/gltf/DamagedHelmet/DamagedHelmet.glb}
SIZE=${SIZE:-512}
REF_SPP=${REF_SPP:-64}
OUT=${OUT:-target/bench-distributed}
RQR=${RQR:-target/debug/rqr}
[ -x "$RQR" ] || cargo build -q
. scripts/env.sh
mkdir -p "$OUT"
run() {
  local name=$1; shift
  "$RQR" compare "$@" --width "$SIZE" --height "$SIZE" --max-depth 3 --repeat 1 --timeout-ms 900000 \
    --reference-spp "$REF_SPP" -o "$OUT/$name" >/dev/null
  python3 - "$OUT/$name/quality.json" "$name" <<'PY'
import json, sys
q = json.load(open(sys.argv[1]))
rows = {(r["config"], r["path"]): r for r in q["rows"]}
print(f"## {sys.argv[2]} ({q['backend']}, reference {q['reference']['spp']} spp, {q['reference']['gpu_ms']:.0f} ms)")
print("| shading | path | GPU ms | FLIP | PSNR dB |")
print("|---|---|---:|---:|---:|")
for r in q["rows"]:
    print(f"| {r['config']} | {r['path']} | {r['gpu_ms']:.1f} | {r['flip_mean']:.4f} | {r['psnr_db']:.2f} |")
for path in ("rt", "hybrid"):
    w = rows[("whitted", path)]["gpu_ms"]
    d = rows[("distributed 1 spp", path)]["gpu_ms"]
    print(f"{path}: distributed 1 spp / Whitted = {d / w:.2f}x ({d:.1f} / {w:.1f} ms)")
PY
}
run built-in --light-radius 0.1
run helmet "$HELMET" --environment assets/environments/sunrise.hdr
