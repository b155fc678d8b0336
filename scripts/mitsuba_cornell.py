#!/usr/bin/env python3
"""A Cornell box for rqr and Mitsuba 3 from one description, and their comparison.

The scene: a 2 x 2 x 2 box (open at +z, the camera side) with Lambert walls (white floor,
ceiling and back wall, red left wall, green right wall), a white Lambert block, a rough grey
metal sphere (base colour 0.9, roughness 0.3) and a sphere light near the ceiling.

Subcommands:
  scene OUT.gltf            write the glTF 2.0 scene rqr renders (embedded base64 buffer)
  mitsuba OUT.exr --spp N   render the same scene with Mitsuba 3's `path` integrator
  compare A.exr B.exr       tonemap both linear EXRs the same way (Khronos PBR Neutral, then
                            sRGB), report mean FLIP (LDR) and PSNR, write PNGs
  check-bsdf                compare Mitsuba's `principled` metal with rqr's metal BSDF
                            (GGX, height-correlated Smith, Schlick Fresnel with F0 = base
                            colour) at a few direction pairs

How the two descriptions are matched:
- Walls and block: glTF metallic 0 with KHR_materials_specular specularFactor 0 (rqr then has
  no dielectric GGX layer, a pure Lambert), Mitsuba `diffuse` (wrapped in `twosided`).
- Metal: glTF metallic 1, roughness 0.3, base colour 0.9. rqr's metal Fresnel is Schlick with
  F0 = base colour; Mitsuba's `principled` BSDF with metallic 1 uses exactly that Schlick
  term (its dielectric part is weighted by 1 - metallic = 0), GGX with alpha = roughness²
  and visible-normal sampling. `roughconductor` would need an eta/k pair whose full
  conductor Fresnel only approximates Schlick, so `principled` is used. The remaining
  difference is Smith's masking: rqr is height-correlated, Mitsuba separable (a few per cent
  at grazing angles only, at alpha 0.09); `check-bsdf` prints both.
- Light: rqr reads a KHR_lights_punctual point light of intensity I (candela) with
  `extras.radius` R, a sphere emitting I / (πR²) radiance that camera rays see and that
  does not block other rays. Mitsuba gets a `sphere` of radius R with an `area` emitter of
  that radiance and a `null` BSDF (rays pass through it, as in rqr).
- Depth: rqr's --max-depth counts segments from the camera (1 = primary + shadow rays);
  Mitsuba's max_depth counts the same segments including the one reaching the light (2 =
  direct light only). With rqr `--diffuse-bounces 8 --max-depth 10`, a path of diffuse
  bounces has at most 10 segments to the light, as Mitsuba's `max_depth` 10.
  Mitsuba counts a pass through the `null` light as two depth levels, so a path through the
  light loses two bounces there (negligible at depth 10; at max_depth 3 Mitsuba 3.9.1 even
  drops the light's own emission: compare shallow depths with `--light-bsdf black`).
- Camera: the glTF camera node (yfov) and Mitsuba's `perspective` with fov_axis `y`,
  box pixel filter in both.
"""
import argparse
import base64
import json
import math
import os
import sys
import time

import numpy as np

# ---------------------------------------------------------------------------------------
# The one description.
# ---------------------------------------------------------------------------------------

CAMERA_POSITION = (0.0, 1.0, 3.9)
CAMERA_TARGET = (0.0, 1.0, 0.0)
CAMERA_YFOV_DEG = 38.0

LIGHT_POSITION = (0.0, 1.7, 0.0)
LIGHT_RADIUS = 0.15
LIGHT_INTENSITY = 2.5  # candela: the sphere's radiance is I / (π R²)

MATERIALS = {
    "white": {"kind": "lambert", "color": (0.73, 0.73, 0.73)},
    "red": {"kind": "lambert", "color": (0.63, 0.065, 0.05)},
    "green": {"kind": "lambert", "color": (0.14, 0.45, 0.091)},
    "metal": {"kind": "metal", "color": (0.9, 0.9, 0.9), "roughness": 0.3},
}


def quad(p0, p1, p2, p3, normal):
    """Two triangles p0 p1 p2, p0 p2 p3 (counter-clockwise seen from `normal`)."""
    pos = np.array([p0, p1, p2, p3], dtype=np.float32)
    nrm = np.array([normal] * 4, dtype=np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], dtype=np.uint32)
    # Orient the winding to the normal.
    e = np.cross(pos[1] - pos[0], pos[2] - pos[0])
    if np.dot(e, normal) < 0:
        idx = np.array([0, 2, 1, 0, 3, 2], dtype=np.uint32)
    return pos, nrm, idx


def merge(parts):
    pos, nrm, idx, base = [], [], [], 0
    for p, n, i in parts:
        pos.append(p)
        nrm.append(n)
        idx.append(i + base)
        base += len(p)
    return np.concatenate(pos), np.concatenate(nrm), np.concatenate(idx)


def block(center, size, angle_deg):
    """A box with outward normals, rotated about +y."""
    cx, cy, cz = center
    sx, sy, sz = (s / 2 for s in size)
    a = math.radians(angle_deg)
    ca, sa = math.cos(a), math.sin(a)

    def xf(x, y, z):
        return (cx + ca * x + sa * z, cy + y, cz - sa * x + ca * z)

    def rot(n):
        x, y, z = n
        return (ca * x + sa * z, y, -sa * x + ca * z)

    faces = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u = [0.0, 0.0, 0.0]
            v = [0.0, 0.0, 0.0]
            u[(axis + 1) % 3] = 1.0
            v[(axis + 2) % 3] = 1.0
            half = (sx, sy, sz)
            corners = []
            for a_, b_ in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [n[k] * half[k] + u[k] * a_ * half[k] + v[k] * b_ * half[k] for k in range(3)]
                corners.append(xf(*p))
            faces.append(quad(*corners, rot(tuple(n))))
    return merge(faces)


def uv_sphere(center, radius, rings=48, segments=96):
    """A UV sphere with smooth (analytic) normals."""
    pos, nrm = [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))
            nrm.append(n)
            pos.append(tuple(center[k] + radius * n[k] for k in range(3)))
    idx = []
    w = segments + 1
    for i in range(rings):
        for j in range(segments):
            a, b, c, d = i * w + j, i * w + j + 1, (i + 1) * w + j + 1, (i + 1) * w + j
            # Counter-clockwise seen from outside.
            if i != 0:
                idx += [a, b, d]
            if i != rings - 1:
                idx += [b, c, d]
    return (np.array(pos, np.float32), np.array(nrm, np.float32), np.array(idx, np.uint32))


def meshes():
    """(name, material, positions, normals, indices) of every mesh."""
    x0, x1, y0, y1, z0, z1 = -1.0, 1.0, 0.0, 2.0, -1.0, 1.0
    white = merge([
        quad((x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1), (0, 1, 0)),  # floor
        quad((x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1), (0, -1, 0)),  # ceiling
        quad((x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0), (0, 0, 1)),  # back
    ])
    red = quad((x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0), (1, 0, 0))
    green = quad((x1, y0, z0), (x1, y0, z1), (x1, y1, z1), (x1, y1, z0), (-1, 0, 0))
    return [
        ("walls", "white", *white),
        ("left_wall", "red", *red),
        ("right_wall", "green", *green),
        ("block", "white", *block((-0.4, 0.6, -0.35), (0.55, 1.2, 0.55), 18.0)),
        ("metal_sphere", "metal", *uv_sphere((0.42, 0.4, 0.25), 0.4)),
    ]


# ---------------------------------------------------------------------------------------
# glTF for rqr.
# ---------------------------------------------------------------------------------------

def write_gltf(path):
    blob = bytearray()
    views, accessors, gl_meshes, nodes = [], [], [], []
    mat_names = list(MATERIALS)

    def add_view(data, target):
        while len(blob) % 4:
            blob.append(0)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
        blob.extend(data)
        return len(views) - 1

    for name, mat, pos, nrm, idx in meshes():
        pv = add_view(pos.astype("<f4").tobytes(), 34962)
        accessors.append({"bufferView": pv, "componentType": 5126, "count": len(pos), "type": "VEC3",
                          "min": pos.min(0).tolist(), "max": pos.max(0).tolist()})
        nv = add_view(nrm.astype("<f4").tobytes(), 34962)
        accessors.append({"bufferView": nv, "componentType": 5126, "count": len(nrm), "type": "VEC3"})
        iv = add_view(idx.astype("<u4").tobytes(), 34963)
        accessors.append({"bufferView": iv, "componentType": 5125, "count": len(idx), "type": "SCALAR"})
        gl_meshes.append({"name": name, "primitives": [{
            "attributes": {"POSITION": len(accessors) - 3, "NORMAL": len(accessors) - 2},
            "indices": len(accessors) - 1, "material": mat_names.index(mat)}]})
        nodes.append({"name": name, "mesh": len(gl_meshes) - 1})

    materials = []
    for name, m in MATERIALS.items():
        if m["kind"] == "lambert":
            materials.append({"name": name, "doubleSided": True, "pbrMetallicRoughness": {
                "baseColorFactor": [*m["color"], 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
                "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}})
        else:
            materials.append({"name": name, "pbrMetallicRoughness": {
                "baseColorFactor": [*m["color"], 1.0], "metallicFactor": 1.0,
                "roughnessFactor": m["roughness"]}})

    nodes.append({"name": "camera", "camera": 0, "translation": list(CAMERA_POSITION)})
    nodes.append({"name": "light", "translation": list(LIGHT_POSITION),
                  "extensions": {"KHR_lights_punctual": {"light": 0}}})
    doc = {
        "asset": {"version": "2.0", "generator": "rqr scripts/mitsuba_cornell.py",
                  "copyright": "CC0 1.0"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_specular"],
        "extensions": {"KHR_lights_punctual": {"lights": [{
            "name": "sphere_light", "type": "point", "color": [1.0, 1.0, 1.0],
            "intensity": LIGHT_INTENSITY, "extras": {"radius": LIGHT_RADIUS}}]}},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": gl_meshes,
        "materials": materials,
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": math.radians(CAMERA_YFOV_DEG), "aspectRatio": 1.0, "znear": 0.01, "zfar": 100.0}}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}],
    }
    with open(path, "w") as f:
        json.dump(doc, f, separators=(",", ":"))
        f.write("\n")


# ---------------------------------------------------------------------------------------
# Mitsuba 3.
# ---------------------------------------------------------------------------------------

def mitsuba_bsdf(m):
    if m["kind"] == "lambert":
        return {"type": "twosided", "material": {
            "type": "diffuse", "reflectance": {"type": "rgb", "value": list(m["color"])}}}
    return {"type": "principled", "base_color": {"type": "rgb", "value": list(m["color"])},
            "metallic": 1.0, "roughness": m["roughness"]}


def mitsuba_scene(mi, width, height, max_depth, light_bsdf="null"):
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth},
        "sensor": {
            "type": "perspective", "fov": CAMERA_YFOV_DEG, "fov_axis": "y",
            "near_clip": 0.01, "far_clip": 100.0,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=list(CAMERA_POSITION), target=list(CAMERA_TARGET), up=[0, 1, 0]),
            "sampler": {"type": "independent"},
            "film": {"type": "hdrfilm", "width": width, "height": height,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb",
                     "component_format": "float32"},
        },
        "light": {
            "type": "sphere", "center": list(LIGHT_POSITION), "radius": LIGHT_RADIUS,
            "bsdf": {"type": "null"} if light_bsdf == "null"
            else {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}},
            "emitter": {"type": "area", "radiance": {
                "type": "rgb", "value": [LIGHT_INTENSITY / (math.pi * LIGHT_RADIUS ** 2)] * 3}},
        },
    }
    for name, mat, pos, nrm, idx in meshes():
        scene[name] = {"type": "ply", "filename": write_ply(name, pos, nrm, idx),
                       "bsdf": mitsuba_bsdf(MATERIALS[mat])}
    return scene


PLY_DIR = None


def write_ply(name, pos, nrm, idx):
    """A binary little-endian PLY with positions, normals and triangles."""
    path = os.path.join(PLY_DIR, name + ".ply")
    faces = idx.reshape(-1, 3)
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(pos)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property float nx\nproperty float ny\nproperty float nz\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(np.hstack([pos, nrm]).astype("<f4").tobytes())
        rec = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", 3)])
        rec["n"] = 3
        rec["i"] = faces
        f.write(rec.tobytes())
    return path


def render_mitsuba(args):
    import mitsuba as mi
    mi.set_variant(args.variant)
    global PLY_DIR
    PLY_DIR = os.path.dirname(os.path.abspath(args.out)) or "."
    scene = mi.load_dict(mitsuba_scene(mi, args.width, args.height, args.max_depth, args.light_bsdf))
    start = time.time()
    img = mi.render(scene, spp=args.spp, seed=args.seed)
    mi.Bitmap(img).write(args.out)
    print(json.dumps({"renderer": "mitsuba", "variant": args.variant, "spp": args.spp,
                      "width": args.width, "height": args.height, "max_depth": args.max_depth,
                      "seconds": round(time.time() - start, 2)}))


# ---------------------------------------------------------------------------------------
# Comparison.
# ---------------------------------------------------------------------------------------

def khronos_neutral(c):
    c = np.maximum(c, 0.0)
    start, desat = 0.8 - 0.04, 0.15
    x = c.min(-1, keepdims=True)
    offset = np.where(x < 0.08, x - 6.25 * x * x, 0.04)
    c = c - offset
    peak = c.max(-1, keepdims=True)
    d = 1.0 - start
    new_peak = 1.0 - d * d / (peak + d - start)
    g = 1.0 - 1.0 / (desat * (peak - new_peak) + 1.0)
    scaled = c * new_peak / np.maximum(peak, 1e-12)
    compressed = scaled * (1 - g) + new_peak * g
    return np.where(peak < start, c, compressed)


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def read_exr(path):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    b = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    return np.array(b, dtype=np.float32)[..., :3]


def write_png(path, ldr):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    q = np.round(np.clip(ldr, 0, 1) * 255).astype(np.uint8)
    mi.Bitmap(q, mi.Bitmap.PixelFormat.RGB).write(path)


def compare(args):
    import flip_evaluator as flip
    ref = read_exr(args.reference)
    test = read_exr(args.test)
    if ref.shape != test.shape:
        sys.exit(f"size mismatch: {args.reference} {ref.shape}, {args.test} {test.shape}")
    ref_ldr = srgb(khronos_neutral(ref)).astype(np.float32)
    test_ldr = srgb(khronos_neutral(test)).astype(np.float32)
    err_map, mean_flip, _ = flip.evaluate(ref_ldr, test_ldr, "LDR")
    mse = float(np.mean((ref_ldr - test_ldr) ** 2))
    psnr = 10 * math.log10(1.0 / mse) if mse > 0 else float("inf")
    # Linear means per channel, without the pixels that see the light in either image (they
    # saturate either way, and a few of them would dominate the mean).
    mask = np.maximum(ref.max(-1), test.max(-1)) < 20.0
    result = {
        "flip_mean": round(float(mean_flip), 4),
        "psnr_db": round(psnr, 2),
        "linear_mean_reference": [round(float(v), 4) for v in ref[mask].mean(0)],
        "linear_mean_test": [round(float(v), 4) for v in test[mask].mean(0)],
        "linear_ratio_test_over_reference": [
            round(float(t / r), 4) for t, r in zip(test[mask].mean(0), ref[mask].mean(0))],
    }
    if args.png_prefix:
        write_png(args.png_prefix + "reference.png", ref_ldr)
        write_png(args.png_prefix + "test.png", test_ldr)
        write_png(args.png_prefix + "flip.png", np.asarray(err_map, np.float32))
    print(json.dumps(result))


def check_bsdf(_args):
    """Mitsuba principled metal against rqr's metal BSDF (times the cosine)."""
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    m = MATERIALS["metal"]
    bsdf = mi.load_dict(mitsuba_bsdf(m))
    alpha = m["roughness"] ** 2
    f0 = np.array(m["color"])

    def rqr_metal(v, l):
        h = v + l
        h /= np.linalg.norm(h)
        nl, nv, nh, vh = l[2], v[2], h[2], v @ h
        a2 = alpha * alpha
        d = a2 / (math.pi * (nh * nh * (a2 - 1) + 1) ** 2)
        gv = nl * math.sqrt(nv * nv * (1 - a2) + a2)
        gl = nv * math.sqrt(nl * nl * (1 - a2) + a2)
        f = f0 + (1 - f0) * (1 - vh) ** 5
        return f * d * 0.5 / (gv + gl) * nl

    ctx = mi.BSDFContext()
    rows = []
    for tv, tl, dphi in ((0, 0, 0), (30, 30, 180), (45, 20, 160), (60, 60, 180), (75, 70, 180), (40, 50, 90)):
        v = np.array([math.sin(math.radians(tv)), 0, math.cos(math.radians(tv))])
        p = math.radians(dphi)
        l = np.array([math.sin(math.radians(tl)) * math.cos(p), math.sin(math.radians(tl)) * math.sin(p),
                      math.cos(math.radians(tl))])
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f([0, 0, 1])
        si.wi = mi.Vector3f(*v)
        mit = bsdf.eval(ctx, si, mi.Vector3f(*l))
        ours = rqr_metal(v, l)
        rows.append({"theta_v": tv, "theta_l": tl, "dphi": dphi, "mitsuba": round(float(mit[0]), 5),
                     "rqr": round(float(ours[0]), 5)})
    for r in rows:
        print(json.dumps(r))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("scene")
    s.add_argument("out")
    m = sub.add_parser("mitsuba")
    m.add_argument("out")
    m.add_argument("--spp", type=int, default=4096)
    m.add_argument("--width", type=int, default=64)
    m.add_argument("--height", type=int, default=64)
    m.add_argument("--max-depth", type=int, default=10)
    m.add_argument("--seed", type=int, default=0)
    m.add_argument("--variant", default="scalar_rgb")
    m.add_argument("--light-bsdf", choices=["null", "black"], default="null",
                   help="the light sphere's surface: `null` (rays pass through, as in rqr) or "
                   "an opaque black `diffuse`")
    c = sub.add_parser("compare")
    c.add_argument("reference")
    c.add_argument("test")
    c.add_argument("--png-prefix")
    sub.add_parser("check-bsdf")
    args = ap.parse_args()
    if args.cmd == "scene":
        write_gltf(args.out)
    elif args.cmd == "mitsuba":
        render_mitsuba(args)
    elif args.cmd == "compare":
        compare(args)
    else:
        check_bsdf(args)


if __name__ == "__main__":
    main()
