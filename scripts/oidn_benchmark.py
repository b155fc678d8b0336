#!/usr/bin/env python3
"""Intel Open Image Denoise on rqr's outputs: a benchmark, not a test.

Renders a jittered 1-spp frame with its albedo and normal guides as PFM (`rqr render -o
color.pfm --aov albedo,normal,depth`) and a many-sample reference, then denoises the frame
with OIDN through pyoidn's Python API (quality "high" and "fast", with and without the
guides) and, when the `oidnDenoise` command-line tool is found (pyoidn's wheel ships it), with
the exact command the user guide documents. Prints MSE and PSNR against the reference and the
denoiser's wall time.

OIDN stays out of rqr's dependencies and tests: install it into a throwaway environment,

    python3 -m venv /tmp/oidn && /tmp/oidn/bin/pip install pyoidn numpy
    /tmp/oidn/bin/python scripts/oidn_benchmark.py --rqr target/release/rqr

rqr's shading is Whitted (deterministic), so the 1-spp noise here is the jittered camera
sample's aliasing, not light-transport noise.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np


def read_pfm(path):
    """A colour PFM as float32 [H, W, 3], rows top to bottom."""
    with open(path, "rb") as f:
        data = f.read()
    tokens, at = [], 0
    while len(tokens) < 4:
        while data[at : at + 1].isspace():
            at += 1
        start = at
        while not data[at : at + 1].isspace():
            at += 1
        tokens.append(data[start:at].decode())
    at += 1
    if tokens[0] != "PF":
        raise ValueError(f"{path}: not a colour PFM ({tokens[0]!r})")
    w, h, scale = int(tokens[1]), int(tokens[2]), float(tokens[3])
    dtype = "<f4" if scale < 0 else ">f4"
    img = np.frombuffer(data, dtype=dtype, count=w * h * 3, offset=at)
    return img.reshape(h, w, 3)[::-1].astype(np.float32)


def write_pfm(path, img):
    h, w, _ = img.shape
    with open(path, "wb") as f:
        f.write(f"PF\n{w} {h}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(img[::-1], dtype="<f4").tobytes())


def mse(a, b):
    return float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))


def mse_display(a, ref):
    """MSE of the values clamped to [0, 1] (as a display shows them: the HDR MSE is dominated
    by the few pixels of the lamp)."""
    return mse(np.clip(a, 0, 1), np.clip(ref, 0, 1))


def psnr(a, ref):
    """PSNR of the values clamped to [0, 1]."""
    e = mse_display(a, ref)
    return float("inf") if e == 0 else 10 * np.log10(1.0 / e)


def scores(a, ref):
    return {"mse": mse_display(a, ref), "psnr": psnr(a, ref), "mse_hdr": mse(a, ref)}


def render(rqr, scene, out, size, spp, sampler, seed, aovs):
    cmd = [rqr, "render"] + ([scene] if scene else [])
    cmd += ["--width", str(size[0]), "--height", str(size[1]), "--spp", str(spp)]
    cmd += ["--sampler", sampler, "--seed", str(seed), "-o", out]
    if aovs:
        cmd += ["--aov", aovs]
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return cmd, time.perf_counter() - t


def oidn_cli():
    try:
        import pyoidn

        shipped = os.path.join(os.path.dirname(pyoidn.__file__), "oidn", "bin", "oidnDenoise")
        if os.path.exists(shipped):
            return shipped
    except ImportError:
        pass
    return shutil.which("oidnDenoise")


def on_frame(folder, repeats):
    """OIDN on the frame `examples/denoise_bench.rs` left in `folder` (raw.pfm with
    guide.albedo.pfm and guide.normal.pfm, the same 1-spp frame rqr's denoiser filtered), scored
    against its reference.pfm next to rqr's own outputs (denoised1.pfm: that frame alone;
    denoised30.pfm: after 30 frames of history)."""
    import pyoidn

    load = lambda name: read_pfm(os.path.join(folder, name))
    ref, color = load("reference.pfm"), load("raw.pfm")
    albedo, normal = load("guide.albedo.pfm"), load("guide.normal.pfm")
    rows = [{"method": "rqr 1 spp, raw", **scores(color, ref), "ms": None},
            {"method": "rqr 16 spp, raw", **scores(load("raw16.pfm"), ref), "ms": None},
            {"method": "rqr svgf, this frame alone", **scores(load("denoised1.pfm"), ref), "ms": None},
            {"method": "rqr svgf, after 30 frames", **scores(load("denoised30.pfm"), ref), "ms": None}]
    for quality in ("high", "fast"):
        times, out = [], None
        for _ in range(repeats):
            t = time.perf_counter()
            out = pyoidn.denoise(color, albedo, normal, hdr=True, quality=quality)
            times.append((time.perf_counter() - t) * 1e3)
        write_pfm(os.path.join(folder, f"oidn_{quality}.pfm"), out)
        rows.append({"method": f"OIDN {quality} + albedo + normal", **scores(out, ref),
                     "ms": sorted(times)[len(times) // 2]})
    return {"folder": folder, "rows": rows}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frame-dir", default=None,
                   help="score OIDN on the frame examples/denoise_bench.rs wrote here, and stop")
    p.add_argument("--rqr", default="target/release/rqr", help="the rqr binary")
    p.add_argument("--scene", default=None, help="glTF file (default: the built-in room)")
    p.add_argument("--size", default="256x256", help="WxH")
    p.add_argument("--reference-spp", type=int, default=256)
    p.add_argument("--repeats", type=int, default=3, help="denoiser runs; the median is kept")
    p.add_argument("--keep", default=None, help="folder to keep the images in")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args()
    if args.frame_dir:
        print(json.dumps(on_frame(args.frame_dir, args.repeats), indent=2))
        return
    import pyoidn

    size = tuple(int(v) for v in args.size.split("x"))
    work = args.keep or tempfile.mkdtemp(prefix="rqr-oidn-")
    os.makedirs(work, exist_ok=True)
    color_path = os.path.join(work, "color.pfm")
    ref_path = os.path.join(work, "reference.pfm")
    noisy_cmd, noisy_s = render(args.rqr, args.scene, color_path, size, 1, "jitter", 7, "albedo,normal,depth")
    _, ref_s = render(args.rqr, args.scene, ref_path, size, args.reference_spp, "sobol", 7, None)
    color = read_pfm(color_path)
    albedo = read_pfm(os.path.join(work, "color.albedo.pfm"))
    normal = read_pfm(os.path.join(work, "color.normal.pfm"))
    ref = read_pfm(ref_path)
    rows = [{"method": "rqr 1 spp (jitter), no denoiser", **scores(color, ref), "ms": None}]
    for quality in ("high", "fast"):
        for guides in (True, False):
            times, out = [], None
            for _ in range(args.repeats):
                t = time.perf_counter()
                out = pyoidn.denoise(
                    color,
                    albedo if guides else None,
                    normal if guides else None,
                    hdr=True,
                    quality=quality,
                )
                times.append((time.perf_counter() - t) * 1e3)
            label = f"OIDN {quality}" + (" + albedo + normal" if guides else ", colour only")
            rows.append({"method": label, **scores(out, ref), "ms": sorted(times)[len(times) // 2]})
            if quality == "high" and guides:
                write_pfm(os.path.join(work, "denoised_pyoidn.pfm"), out)
                high_guided = out
    cli = oidn_cli()
    cli_result = None
    if cli:
        out_path = os.path.join(work, "denoised.pfm")
        cmd = [cli, "--hdr", color_path, "--alb", os.path.join(work, "color.albedo.pfm"),
               "--nrm", os.path.join(work, "color.normal.pfm"), "-o", out_path]
        t = time.perf_counter()
        run = subprocess.run(cmd, capture_output=True, text=True)
        wall = (time.perf_counter() - t) * 1e3
        if run.returncode == 0:
            out = read_pfm(out_path)
            cli_result = {
                "command": " ".join(["oidnDenoise"] + cmd[1:]),
                **scores(out, ref),
                "process_ms": wall,
                "max_abs_diff_vs_pyoidn_high": float(np.max(np.abs(out - high_guided))),
            }
        else:
            cli_result = {"command": " ".join(cmd), "error": run.stderr.strip()[-500:]}
    result = {
        "scene": args.scene or "built-in",
        "size": list(size),
        "reference_spp": args.reference_spp,
        "rqr_command": " ".join(noisy_cmd),
        "rqr_render_s": {"noisy": noisy_s, "reference": ref_s},
        "guides": {
            "albedo_range": [float(albedo.min()), float(albedo.max())],
            "normal_length_on_hits": float(np.median(np.linalg.norm(normal, axis=2)[np.linalg.norm(normal, axis=2) > 0])) if np.any(normal) else 0.0,
        },
        "rows": rows,
        "oidnDenoise": cli_result,
        "folder": work,
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print(f"{result['scene']} {size[0]}x{size[1]}, reference {args.reference_spp} spp (sobol); images in {work}")
    print("| method | MSE (clamped to [0, 1]) | PSNR (dB) | HDR MSE | denoiser ms |")
    print("|---|---|---|---|---|")
    for r in rows:
        ms = "" if r["ms"] is None else f"{r['ms']:.0f}"
        print(f"| {r['method']} | {r['mse']:.3e} | {r['psnr']:.2f} | {r['mse_hdr']:.3g} | {ms} |")
    if cli_result:
        print(f"oidnDenoise: {json.dumps(cli_result)}")
    else:
        print("oidnDenoise: not found (pyoidn ships it in pyoidn/oidn/bin)")


if __name__ == "__main__":
    sys.exit(main())
