#!/usr/bin/env bash
# Throughput of `rqr batch` against one `rqr render` process per view (today's way), on the
# glTF models of a directory (default ../shared/gltf, its INDEX.tsv): N orbit views per model
# at SIZE². Runs, in order:
#   1. `rqr batch`, cold: empty RQR_CACHE_DIR (pipeline cache) and empty Mesa shader cache;
#   2. `rqr batch` again (--force), with both caches warm;
#   3. one `rqr render` process per view, same cameras (from the results' c2w), caches warm.
# Prints views per minute of each, the speed-up, and the per-stage time table of run 2.
# Usage: scripts/bench-batch.sh [MODELS_DIR] [VIEWS] [SIZE] [MAX_MODELS]
#        (defaults: ../shared/gltf 4 256 all). RQR_BIN=path uses that binary (default: a
#        release build).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/env.sh
models=${1:-../shared/gltf}
views=${2:-4}
size=${3:-256}
max=${4:-0}
if [ -z "${RQR_BIN:-}" ]; then
  cargo build --release -q
  RQR_BIN=target/release/rqr
fi
rqr=$(realpath "$RQR_BIN")
out=$(realpath -m bench-batch)
rm -rf "$out"
mkdir -p "$out/cache" "$out/mesa"
export RQR_CACHE_DIR=$out/cache MESA_SHADER_CACHE_DIR=$out/mesa RQR_NO_AUTOTUNE=1
python3 - "$models" "$views" "$size" "$max" > "$out/manifest.jsonl" <<'PY'
import csv, json, os, sys
models, views, size, limit = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
rows = list(csv.DictReader(open(os.path.join(models, "INDEX.tsv")), delimiter="\t"))
if limit:
    rows = rows[:limit]
print(json.dumps({"defaults": {"width": size, "height": size,
                  "cameras": {"orbit": {"n": views, "elevation_deg": [0, 35], "seed": 1}}}}))
for r in rows:
    print(json.dumps({"id": r["name"], "scene": os.path.realpath(os.path.join(models, r["main_file"]))}))
PY
jobs=$(($(wc -l < "$out/manifest.jsonl") - 1))
echo "$jobs models x $views views at ${size}², binary $rqr"
timed() { # name command...: wall seconds into $out/name.s
  local name=$1; shift
  local t0 t1
  t0=$(date +%s.%N)
  "$@" > "$out/$name.log" 2>&1 || true
  t1=$(date +%s.%N)
  python3 -c 'import sys; print(float(sys.argv[1]) - float(sys.argv[2]))' "$t1" "$t0" > "$out/$name.s"
}
timed batch_cold "$rqr" batch "$out/manifest.jsonl" --out "$out/batch"
cp "$out/batch/results-0-of-1.jsonl" "$out/results_cold.jsonl"
timed batch_warm "$rqr" batch "$out/manifest.jsonl" --out "$out/batch" --force
cp "$out/batch/results-0-of-1.jsonl" "$out/results_warm.jsonl"
# One process per view, with the cameras batch rendered (look-from = translation, look-at =
# one unit down -Z, up +Y: the orbit's own construction).
mkdir -p "$out/per_view"
python3 - "$out" "$rqr" "$size" <<'PY'
import json, os, subprocess, sys, time
out, rqr, size = sys.argv[1], sys.argv[2], sys.argv[3]
scenes = {}
for line in open(os.path.join(out, "manifest.jsonl")):
    j = json.loads(line)
    if "id" in j:
        scenes[j["id"]] = j["scene"]
commands = []
for line in open(os.path.join(out, "results_warm.jsonl")):
    r = json.loads(line)
    if r["status"] != "ok":
        continue
    for k, c in enumerate(r["cameras"]):
        m = c["c2w"]
        frm = [m[0][3], m[1][3], m[2][3]]
        at = [frm[i] - m[i][2] for i in range(3)]
        f = lambda v: ",".join(repr(x) for x in v)
        commands.append([r["id"], rqr, "render", scenes[r["id"]], "--width", size, "--height", size,
                         "--look-from=" + f(frm), "--look-at=" + f(at), "--fov", repr(c["fov_y_deg"]),
                         "-o", os.path.join(out, "per_view", f'{r["id"]}_{k:03}.png')])
failed = 0
per_job = {}
t0 = time.time()
for c in commands:
    t = time.time()
    failed += subprocess.run(c[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode != 0
    per_job[c[0]] = per_job.get(c[0], 0.0) + time.time() - t
open(os.path.join(out, "per_view.s"), "w").write(f"{time.time() - t0}\n")
json.dump(per_job, open(os.path.join(out, "per_view_jobs.json"), "w"))
open(os.path.join(out, "per_view.n"), "w").write(f"{len(commands) - failed}\n")
PY
per_view_views=$(cat "$out/per_view.n")
python3 - "$out" "$per_view_views" <<'PY'
import json, os, sys
out, per_view_views = sys.argv[1], int(sys.argv[2])
sec = lambda n: float(open(os.path.join(out, n + ".s")).read())
def views(n):
    return sum(json.loads(l)["views"] for l in open(os.path.join(out, n)) if json.loads(l)["status"] == "ok")
cold, warm, per = sec("batch_cold"), sec("batch_warm"), sec("per_view")
vc, vw = views("results_cold.jsonl"), views("results_warm.jsonl")
failed = sum(1 for l in open(os.path.join(out, "results_warm.jsonl")) if json.loads(l)["status"] == "failed")
print(f"| run | views | wall s | views/min |\n|---|---:|---:|---:|")
for name, v, s in [("rqr batch, cold caches", vc, cold), ("rqr batch, warm caches", vw, warm), ("rqr render per view, warm caches", per_view_views, per)]:
    print(f"| {name} | {v} | {s:.1f} | {60 * v / s:.1f} |")
print(f"\nbatch (warm) / per-view processes: {(vw / warm) / (per_view_views / per):.1f}x views per minute; warm / cold batch: {(vw / warm) / (vc / cold):.2f}x ({failed} jobs failed)")
# The same comparison without the jobs whose rendering alone takes over a second per view
# (there the GPU work, not start-up, bounds both ways).
per_job = json.load(open(os.path.join(out, "per_view_jobs.json")))
light = [json.loads(l) for l in open(os.path.join(out, "results_warm.jsonl"))]
light = [r for r in light if r["status"] == "ok" and r["times"]["render_gpu_ms"] < 1000 * r["views"] and r["id"] in per_job]
if light:
    lv = sum(r["views"] for r in light)
    lb = sum(r["times"]["total_ms"] for r in light) / 1e3
    lp = sum(per_job[r["id"]] for r in light)
    print(f"without render-bound jobs ({len(light)} of {len(per_job)} models, {lv} views): batch jobs {lb:.1f} s vs per-view processes {lp:.1f} s: {lp / lb:.1f}x")
# What bounds the ratio: the render-bound jobs' GPU time, which a process per view pays too.
heavy = [json.loads(l) for l in open(os.path.join(out, "results_warm.jsonl"))]
heavy = [r for r in heavy if r["status"] == "ok" and r["times"]["render_gpu_ms"] >= 1000 * r["views"]]
if heavy:
    hg = sum(r["times"]["render_gpu_ms"] for r in heavy) / 1e3
    print(f"render-bound jobs ({', '.join(r['id'] for r in heavy)}): {hg:.1f} s of GPU time in the warm batch's {warm:.1f} s; "
          f"with nothing else, batch could reach at most {per / hg:.1f}x")
stages = ["load_ms", "texture_decode_ms", "upload_ms", "accel_build_ms", "render_gpu_ms", "render_wall_ms", "readback_ms", "encode_ms", "total_ms"]
rows = [json.loads(l) for l in open(os.path.join(out, "results_warm.jsonl"))]
rows = [r for r in rows if r["status"] == "ok"]
tot = {s: sum(r["times"][s] for r in rows) for s in stages}
print("\n| stage (warm batch, all jobs) | total s | per view ms |\n|---|---:|---:|")
for s in stages:
    print(f"| {s[:-3]} | {tot[s] / 1e3:.2f} | {tot[s] / max(vw, 1):.1f} |")
PY
