#!/usr/bin/env bash
# Wall time of N views (default 12) at SIZE² (default 256) of one scene: one `render` call of
# the Python package on a scene loaded once, against N separate `rqr render` processes (each
# loading the scene, opening the device and building the acceleration structures).
# Usage: scripts/bench-python.sh [SCENE.glb] (default: assets/gltf/Avocado/Avocado.gltf).
# Needs the package installed (scripts/test-python.sh leaves one in target/python-venv).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/env.sh
scene="${1:-assets/gltf/Avocado/Avocado.gltf}"
views="${VIEWS:-12}"
size="${SIZE:-256}"
python="${RQR_PY:-target/python-venv/bin/python}"
cli="${RQR_CLI:-target/debug/rqr}"
[ -x "$cli" ] || cargo build --bin rqr
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$python" - "$scene" "$views" "$size" "$cli" "$tmp" <<'PY'
import json, subprocess, sys, time
import numpy as np
import rqr

scene_path, n, size, cli, tmp = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
t0 = time.perf_counter()
with rqr.Renderer() as r:
    t_open = time.perf_counter()
    scene = r.load(scene_path)
    t_load = time.perf_counter()
    cams = rqr.Cameras.orbit(scene.bounds, n=n, elevation_deg=20, fov_y_deg=40, seed=7)
    # Warm-up (pipelines are built on first use), then the timed batch.
    r.render(scene, rqr.Cameras(c2w=cams.c2w[:1], fov_y_deg=40), size, size, aovs=("rgb",))
    t1 = time.perf_counter()
    out = r.render(scene, cams, size, size, aovs=("rgb",))
    t_render = time.perf_counter() - t1
    backend = r.device["backend"]
t_total = time.perf_counter() - t0
# The same cameras through the CLI, one process each.
t2 = time.perf_counter()
for i in range(n):
    c = cams.c2w[i]
    eye = c[:3, 3]
    at = eye - c[:3, 2]
    subprocess.run([cli, "render", scene_path, "--width", str(size), "--height", str(size),
                    "--backend", backend, "--look-from=" + ",".join(map(str, eye)), "--look-at=" + ",".join(map(str, at)),
                    "--fov", "40", "-o", f"{tmp}/v{i}.png"], check=True, capture_output=True)
t_cli = time.perf_counter() - t2
print(json.dumps({
    "scene": scene_path, "views": n, "size": size, "backend": backend,
    "python_render_call_s": round(t_render, 3),
    "python_total_s_open_load_warm_render": round(t_total, 3),
    "python_open_s": round(t_open - t0, 3), "python_load_s": round(t_load - t_open, 3),
    "cli_processes_s": round(t_cli, 3),
    "speedup_render_call": round(t_cli / t_render, 2),
    "speedup_total": round(t_cli / t_total, 2),
}, indent=2))
PY
