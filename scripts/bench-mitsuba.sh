#!/usr/bin/env bash
# rqr's distributed model (a path tracer with --diffuse-bounces) against Mitsuba 3's `path`
# integrator on one Cornell box (diffuse walls, a sphere light, a rough metal sphere), built
# for both from scripts/mitsuba_cornell.py. Both images are linear EXRs, tonemapped the same
# way (Khronos PBR Neutral, sRGB) before mean FLIP (LDR) and PSNR; wall times of both.
#
# Mitsuba stays out of rqr's dependencies: it lives in its own virtual environment
# ($MITSUBA_VENV, created with mitsuba, numpy and flip-evaluator from PyPI when missing).
#
# usage: scripts/bench-mitsuba.sh [SIZE] [SPP] [OUT_DIR]   (default 96 4096 target/bench-mitsuba)
# env:   RQR (binary; default target/release/rqr, built when missing), MITSUBA_VENV,
#        MITSUBA_VARIANT (default scalar_rgb)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
size=${1:-96}
spp=${2:-4096}
out=${3:-$root/target/bench-mitsuba}
venv=${MITSUBA_VENV:-$root/target/mitsuba-venv}
variant=${MITSUBA_VARIANT:-scalar_rgb}
. "$root/scripts/env.sh"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet mitsuba numpy flip-evaluator
fi
rqr=${RQR:-$root/target/release/rqr}
if [ ! -x "$rqr" ]; then
    cargo build --release --quiet --manifest-path "$root/Cargo.toml" --bin rqr
fi
py="$venv/bin/python"
script="$root/scripts/mitsuba_cornell.py"
mkdir -p "$out"
"$py" "$script" scene "$out/cornell.gltf"

now() { date +%s.%N; }
t0=$(now)
# --max-depth 10 with 8 diffuse bounces: at most 10 segments from the camera to the light on a
# diffuse path, as Mitsuba's max_depth 10. The timeout covers the single long submission.
"$rqr" render "$out/cornell.gltf" --shading distributed --diffuse-bounces 8 --max-depth 10 \
    --spp "$spp" --sampler sobol --ambient 0 --background 0 --width "$size" --height "$size" \
    --timeout-ms 3600000 -o "$out/rqr.exr" --json > "$out/rqr.json"
t1=$(now)
"$py" "$script" mitsuba "$out/mitsuba.exr" --spp "$spp" --width "$size" --height "$size" \
    --max-depth 10 --variant "$variant" > "$out/mitsuba.json"
t2=$(now)
"$py" "$script" compare "$out/mitsuba.exr" "$out/rqr.exr" --png-prefix "$out/" > "$out/compare.json"
mv "$out/reference.png" "$out/mitsuba.png"
mv "$out/test.png" "$out/rqr.png"
"$py" - "$out" "$t0" "$t1" "$t2" "$size" "$spp" <<'PY'
import json, sys
out, t0, t1, t2, size, spp = sys.argv[1:]
c = json.load(open(f"{out}/compare.json"))
r = json.load(open(f"{out}/rqr.json"))
print(f"Cornell box {size}x{size}, {spp} spp: rqr {float(t1) - float(t0):.1f} s wall "
      f"({r['total_gpu_ms'] / 1000:.1f} s GPU, {r['device']}, backend {r['backend']}), "
      f"Mitsuba 3 {float(t2) - float(t1):.1f} s wall")
print(f"mean FLIP {c['flip_mean']}, PSNR {c['psnr_db']} dB, "
      f"linear mean rqr/Mitsuba {c['linear_ratio_test_over_reference']}")
print(f"images: {out}/rqr.png {out}/mitsuba.png {out}/flip.png")
PY
