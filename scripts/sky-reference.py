#!/usr/bin/env python3
"""Independent float64 evaluation of the Hosek-Wilkie RGB sky model, straight from the
published dataset and reference C code (ArHosekSkyModelData_RGB.h / ArHosekSkyModel.c, BSD,
as shipped in pbrt-v4's src/ext/skymodel/), for cross-checking `rqr::environment::sky`.

Usage: sky-reference.py PATH/TO/ArHosekSkyModelData_RGB.h
Prints `(turbidity, sun elevation°, zenith angle θ°, azimuth from the sun°, [R, G, B])` rows,
the table of tests/render/environment_sky.rs (ground albedo 0.3, the model's own units).
"""
import math
import re
import sys


def datasets(path):
    text = re.sub(r"//[^\n]*", "", open(path).read())
    out = {}
    for name, body in re.findall(r"double\s+(datasetRGB(?:Rad)?\d)\[\]\s*=\s*\{(.*?)\};", text, re.S):
        out[name] = [float(x) for x in re.findall(r"[-+]?\d*\.?\d+(?:[eE][-+]?\d+)?", body)]
    return out


def bezier(m, stride, t):
    c = [1, 5, 10, 10, 5, 1]
    return sum(c[k] * (1 - t) ** (5 - k) * t ** k * m[k * stride] for k in range(6))


def cook(dataset, n, turbidity, albedo, elevation):
    """ArHosekSkyModel_CookConfiguration (n = 9) / CookRadianceConfiguration (n = 1)."""
    ti = int(turbidity)
    tr = turbidity - ti
    t = (elevation / (math.pi / 2)) ** (1 / 3)
    out = [0.0] * n
    parts = [(0, ti - 1, (1 - albedo) * (1 - tr)), (n * 6 * 10, ti - 1, albedo * (1 - tr))]
    if ti != 10:
        parts += [(0, ti, (1 - albedo) * tr), (n * 6 * 10, ti, albedo * tr)]
    for base, turb, weight in parts:
        m = dataset[base + n * 6 * turb:]
        for i in range(n):
            out[i] += weight * bezier(m[i:], n, t)
    return out


def radiance(cfg, rad, theta, gamma):
    exp_m = math.exp(cfg[4] * gamma)
    ray_m = math.cos(gamma) ** 2
    mie_m = (1 + math.cos(gamma) ** 2) / (1 + cfg[8] ** 2 - 2 * cfg[8] * math.cos(gamma)) ** 1.5
    zenith = math.sqrt(math.cos(theta))
    return rad * (1 + cfg[0] * math.exp(cfg[1] / (math.cos(theta) + 0.01))) * (
        cfg[2] + cfg[3] * exp_m + cfg[5] * ray_m + cfg[6] * mie_m + cfg[7] * zenith)


def main():
    d = datasets(sys.argv[1])
    albedo = 0.3
    for turbidity in (2.0, 3.0, 6.0):
        for elev_deg in (5.0, 30.0, 60.0):
            e = math.radians(elev_deg)
            cfgs = [cook(d[f"datasetRGB{c}"], 9, turbidity, albedo, e) for c in (1, 2, 3)]
            rads = [cook(d[f"datasetRGBRad{c}"], 1, turbidity, albedo, e)[0] for c in (1, 2, 3)]
            ts = math.pi / 2 - e
            # Directions by zenith angle and azimuth from the sun.
            for theta_deg, dphi_deg in ((0.0, 0.0), (80.0, 180.0), (60.0, 0.0), (45.0, 90.0)):
                th, dp = math.radians(theta_deg), math.radians(dphi_deg)
                cg = math.cos(th) * math.cos(ts) + math.sin(th) * math.sin(ts) * math.cos(dp)
                g = math.acos(max(-1.0, min(1.0, cg)))
                rgb = [radiance(cfgs[c], rads[c], th, g) for c in range(3)]
                print(f"    ({turbidity:.1f}, {elev_deg:.1f}, {theta_deg:.1f}, {dphi_deg:.1f}, ["
                      + ", ".join(f"{v:.6}" for v in rgb) + "]),")


if __name__ == "__main__":
    main()
