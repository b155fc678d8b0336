"""Renders N views of a glTF into a NeRF-style dataset:

    out/images/r_000.png ...    8-bit sRGB views
    out/depth/r_000.npy ...     float32 ray distance per pixel (+inf on a miss)
    out/transforms.json         OpenGL camera-to-world matrices and intrinsics

Usage: python nerf_dataset.py [SCENE.glb] [-o OUT] [-n 12] [--size 512]
(without SCENE: the built-in scene; e.g. DamagedHelmet.glb from the Khronos glTF samples).
"""

import argparse
import json
import os
import struct
import zlib

import numpy as np

import rqr


def write_png(path: str, rgb: np.ndarray) -> None:
    """A minimal RGB8 PNG writer (no imaging dependency)."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(raw, 6)))
        f.write(chunk(b"IEND", b""))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", nargs="?", help="glTF/GLB file (default: the built-in scene)")
    ap.add_argument("-o", "--out", default="nerf_dataset")
    ap.add_argument("-n", "--views", type=int, default=12)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--environment", help="equirectangular .hdr/.exr lighting the scene")
    args = ap.parse_args()

    os.makedirs(os.path.join(args.out, "images"), exist_ok=True)
    os.makedirs(os.path.join(args.out, "depth"), exist_ok=True)
    with rqr.Renderer() as r:
        print("device:", r.device["name"], "backend:", r.device["backend"], f"({r.device['backend_reason']})")
        scene = r.load(args.scene)
        cams = rqr.Cameras.orbit(scene.bounds, n=args.views, elevation_deg=(-10, 40), fov_y_deg=40, seed=7)
        out = r.render(scene, cams, args.size, args.size, environment=args.environment,
                       aovs=("rgb", "depth"), tonemap="khronos_neutral")
    names = []
    for i in range(args.views):
        name = f"r_{i:03d}"
        write_png(os.path.join(args.out, "images", name + ".png"), out.rgb[i])
        np.save(os.path.join(args.out, "depth", name + ".npy"), out.depth[i])
        names.append(f"images/{name}.png")
    transforms = out.transforms(names)
    transforms["depth_unit"] = "ray distance in scene units (+inf on a miss)"
    for frame, name in zip(transforms["frames"], names):
        frame["depth_file_path"] = name.replace("images/", "depth/").replace(".png", ".npy")
    with open(os.path.join(args.out, "transforms.json"), "w") as f:
        json.dump(transforms, f, indent=2)
    stats = out.stats
    print(f"{args.views} views {args.size}x{args.size}: {stats['wall_ms']['total']:.0f} ms wall, "
          f"{stats['rays']['total']} rays -> {args.out}/transforms.json")


if __name__ == "__main__":
    main()
