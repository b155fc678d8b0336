#!/usr/bin/env bash
# The denoiser's benchmark on its three scenes (examples/denoise_bench.rs; JSON per scene
# under $OUT): the built-in room with 0.1-unit sphere lights, DamagedHelmet under
# sunrise.hdr, CornellBox_kajiya with a rough metal sphere added; then CesiumMan walking for
# ghosting, and OIDN (high, fast) on each scene's frame 30 when a Python with pyoidn is given.
#   SIZE=192 REF_SPP=1024 COST_SIZE=512 OIDN_PYTHON=/tmp/oidn-venv/bin/python \
#     scripts/bench-denoise.sh ../shared
# (OIDN: python3 -m venv /tmp/oidn-venv && /tmp/oidn-venv/bin/pip install pyoidn numpy.)
# REF_CACHE=DIR keeps the three scenes' references between runs (a run that changes only the
# denoiser then renders none: at 512², 9 minutes a scene become 1–2). Empty it when the
# shading changes: the key names the scene and settings, not the code. Ghosting's per-pose
# references are not kept.
set -euo pipefail
cd "$(dirname "$0")/.."
shared=${1:?usage: scripts/bench-denoise.sh SHARED_DIR (with gltf/ and env/)}
SIZE=${SIZE:-192}
REF_SPP=${REF_SPP:-1024}
COST_SIZE=${COST_SIZE:-512}
OUT=${OUT:-target/bench-denoise}
. scripts/env.sh
# GPU work dominates (lavapipe runs it on its own threads): the debug build times the same.
cargo build --example denoise_bench >&2
bench=target/debug/examples/denoise_bench
mkdir -p "$OUT"
run() {
  local name=$1
  shift
  echo "== $name" >&2
  "$bench" --size "$SIZE" --reference-spp "$REF_SPP" --cost-size "$COST_SIZE" \
    ${REF_CACHE:+--reference-cache "$REF_CACHE"} --out "$OUT/$name" "$@" > "$OUT/$name.json"
  if [ -n "${OIDN_PYTHON:-}" ]; then
    "$OIDN_PYTHON" scripts/oidn_benchmark.py --frame-dir "$OUT/$name" > "$OUT/$name-oidn.json"
  fi
}
run builtin --light-radius 0.1
run helmet "$shared/gltf/DamagedHelmet/DamagedHelmet.glb" --environment "$shared/env/sunrise.hdr"
run cornell "$shared/gltf/CornellBox_kajiya/scene.gltf" --add-rough-sphere
echo "== ghosting" >&2
"$bench" --size "$SIZE" --reference-spp "$((REF_SPP / 4))" --ghosting \
  --environment "$shared/env/sunrise.hdr" --out "$OUT/ghosting" \
  "$shared/gltf/CesiumMan/CesiumMan.glb" > "$OUT/ghosting.json"
echo "results in $OUT" >&2
