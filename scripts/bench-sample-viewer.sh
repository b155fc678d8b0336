#!/usr/bin/env bash
# Parity with the Khronos glTF Sample Viewer under image-based lighting: renders the models of
# the Sample Viewer references (DamagedHelmet, MetalRoughSpheresNoTextures under studio.hdr
# and sunrise.hdr, 512², the references' camera, exposure 1, Khronos PBR Neutral) with rqr's
# Whitted model, and prints the YIQ colour-distance RMS of each against the reference
# (whole image; background taken from one image into both; object alone).
# usage: scripts/bench-sample-viewer.sh [REFERENCES_DIR]
#   REFERENCES_DIR: the Sample Viewer harness's references/ (with its parity.py one level up);
#   needs Python 3 with numpy, Pillow and OpenEXR.
set -euo pipefail
cd "$(dirname "$0")/.."
REF=${1:-../shared/sample-viewer/references}
PARITY=${PARITY:-$REF/../parity.py}
OUT=${OUT:-target/bench-sample-viewer}
RQR=${RQR:-target/release/rqr}
mkdir -p "$OUT"
[ -x "$RQR" ] || cargo build --release -q
for model in DamagedHelmet MetalRoughSpheresNoTextures; do
  for env in studio sunrise; do
    img="$OUT/${model}_${env}.png"
    "$RQR" render "$REF/$model.glb" --camera 0 --width 512 --height 512 --exposure 0 \
      --tonemap khronos-neutral --environment "$REF/$env.hdr" --aov instance -o "$img" >/dev/null
    printf '%-28s %-8s ' "$model" "$env"
    python3 "$PARITY" "$REF/${model}_${env}.png" "$img" "${img%.png}.instance.exr"
  done
done
