#!/usr/bin/env python3
"""The README's denoising picture from a `scripts/bench-denoise.sh` output folder: per scene,
1 spp, svgf on that frame alone, svgf after 30 frames and the reference, labelled.

    python3 scripts/denoise-pictures.py target/bench-denoise docs/images/denoise.png [REF_SPP]

Needs Pillow (pip install pillow).
"""
import sys
from pathlib import Path

from PIL import Image, ImageDraw

SCENES = [
    ("builtin", "built-in, --light-radius 0.1"),
    ("helmet", "DamagedHelmet, sunrise.hdr"),
    ("cornell", "CornellBox_kajiya + rough metal sphere"),
]
COLUMNS = [
    ("raw.png", "1 spp"),
    ("denoised1.png", "svgf, one frame"),
    ("denoised30.png", "svgf, frame 30"),
    ("reference.png", "{spp} spp"),
]
LABEL = 16


def main() -> int:
    if len(sys.argv) not in (3, 4):
        print(__doc__, file=sys.stderr)
        return 2
    folder, out = Path(sys.argv[1]), Path(sys.argv[2])
    rows = []
    for name, caption in SCENES:
        images = []
        for file, _ in COLUMNS:
            path = folder / name / file
            if not path.is_file():
                print(f"{path}: missing (run scripts/bench-denoise.sh first)", file=sys.stderr)
                return 1
            images.append(Image.open(path).convert("RGB"))
        rows.append((caption, images))
    side = rows[0][1][0].width
    spp = sys.argv[3] if len(sys.argv) > 3 else "1024"
    sheet = Image.new("RGB", (side * len(COLUMNS), len(rows) * (side + LABEL) + LABEL), "white")
    draw = ImageDraw.Draw(sheet)
    for k, (_, title) in enumerate(COLUMNS):
        draw.text((k * side + 2, 2), title.format(spp=spp), fill="black")
    for r, (caption, images) in enumerate(rows):
        top = LABEL + r * (side + LABEL)
        for k, image in enumerate(images):
            sheet.paste(image, (k * side, top))
        draw.text((2, top + side + 2), caption, fill="black")
    sheet.save(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
