#!/usr/bin/env bash
# Renders docs/images/environment.png: four glTF sample models without an environment (the
# default light rig), under studio.hdr and under sunrise.hdr, ray traced at 256².
# usage: scripts/figure-environment.sh [GLTF_DIR] [ENV_DIR]   (Python 3 with Pillow)
set -euo pipefail
cd "$(dirname "$0")/.."
GLTF=${1:-../shared/gltf}
ENV=${2:-../shared/env}
OUT=${OUT:-target/figure-environment}
mkdir -p "$OUT"
cargo build -q
MODELS=(DamagedHelmet/DamagedHelmet.glb WaterBottle/WaterBottle.gltf ToyCar/ToyCar.gltf
        MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb)
for m in "${MODELS[@]}"; do
  name=$(basename "${m%.*}")
  target/debug/rqr render "$GLTF/$m" --width 256 --height 256 -o "$OUT/$name-none.png"
  for e in studio sunrise; do
    target/debug/rqr render "$GLTF/$m" --width 256 --height 256 --environment "$ENV/$e.hdr" \
      -o "$OUT/$name-$e.png"
  done
done
python3 - "$OUT" <<'PY'
import sys
from PIL import Image, ImageDraw
out = sys.argv[1]
names = ["DamagedHelmet", "WaterBottle", "ToyCar", "MetalRoughSpheresNoTextures"]
rows = [("none", "default lights, no environment"), ("studio", "studio.hdr"), ("sunrise", "sunrise.hdr")]
sheet = Image.new("RGB", (4 * 256, 3 * 256))
draw = ImageDraw.Draw(sheet)
for r, (key, label) in enumerate(rows):
    for c, n in enumerate(names):
        sheet.paste(Image.open(f"{out}/{n}-{key}.png").convert("RGB"), (c * 256, r * 256))
    draw.text((6, r * 256 + 4), label, fill=(255, 255, 255))
sheet.save("docs/images/environment.png")
PY
echo "wrote docs/images/environment.png"
