#!/usr/bin/env bash
# GPU benchmarks in one run of about 8-10 minutes on an NVIDIA H200 (after the machine starts):
# reuse between frames against full frames, `rqr compare` frame-time stability and wall time
# (1080p and 4K), the hybrid visibility pass with the compute rasterizer against the graphics
# pipeline, GPU against host BVH builds, a 1M-triangle render end to end, and the per-frame
# animation update. Run from the project root on the GPU machine, with .gpu/ holding the
# release binary (copied to /tmp/rqr), the NVIDIA loader environment (.gpu/nvidia-env.sh),
# the bumpy sphere meshes and CornellBox_kajiya:
#
#   bash scripts/bench-gpu.sh
#
# Results: $OUT/bench-gpu-log.txt and $OUT/bench-gpu-results.tgz (every command's
# stdout/stderr, JSON lines, compare reports). Each step has its own timeout and the archive
# is rewritten after every step, so a run cut short still returns what it finished.
#
# Dry run on a development machine (lavapipe, tiny sizes, no .gpu/ needed; MESHES and KAJIYA
# name the bumpy sphere folder and CornellBox_kajiya's scene.gltf):
#   DRY_RUN=1 MESHES=path/to/meshes KAJIYA=path/to/scene.gltf bash scripts/bench-gpu.sh
#
# Measured (1920x1080 unless said):
#   frame reuse   reprojected / adaptive / frameless frame GPU time over the full frame (burst
#                 timing, built-in and CornellBox_kajiya); two `compare --repeat 50` runs
#                 (agreement, wall time); `compare --repeat 50` at 4K (wall time).
#   visibility    the hybrid visibility pass, compute rasterizer vs graphics pipeline.
#   BVH build     GPU vs host build of the 1M and 100k bumpy spheres (build ms per phase, trace
#                 Mrays/s); `rqr render` of the 1M mesh end to end.
#   animation     per-frame animation update of CesiumMan (skin/morph + acceleration structures).
#   batch         `rqr batch` views per minute, cold and warm caches, against one `rqr render`
#                 process per view (scripts/bench-batch.sh on assets/gltf).
#   textures      the autotune measurement of BC7 against RGBA8 sampling, in a cache of its
#                 own (`rqr probe --json`: texture_block_ms, texture_rgba8_ms, texture_format).
set -u
NAME=bench-gpu
. scripts/bench-gpu-steps.sh
if [ -n "${DRY_RUN:-}" ]; then
  . scripts/env.sh
  RQR=${RQR:-target/release/rqr}; W=${W:-96}; H=${H:-64}; W4=${W4:-128}; H4=${H4:-72}
  MESHES=${MESHES:-../shared/meshes}; KAJIYA=${KAJIYA:-../shared/gltf/CornellBox_kajiya/scene.gltf}
  FRAMES=${FRAMES:-4}; REPEAT=${REPEAT:-3}; BATCH_SIZE=${BATCH_SIZE:-32}; BATCH_MODELS=${BATCH_MODELS:-4}
else
  . .gpu/nvidia-env.sh
  nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv,noheader || true
  RQR=/tmp/rqr; W=1920; H=1080; W4=3840; H4=2160
  MESHES=.gpu; KAJIYA=.gpu/gltf/CornellBox_kajiya/scene.gltf
  FRAMES=60; REPEAT=50
fi
CAM="--look-from 0,0,2.5 --look-at 0,0,0 --fov 45"
export RQR_NO_AUTOTUNE=${RQR_NO_AUTOTUNE:-}
# Summary line of a sequence run: rays, FLIP and GPU time against the full renders.
summary() {
  tail -n 1 "$R/$1.out" | python3 -c '
import json, sys
s = json.loads(sys.stdin.read())["summary"]
passes = ", ".join("%s %.3f" % (p["name"], p["median"]) for p in s["passes"])
print("    %s: rays %.3f, FLIP %.4f, reusing frame %.3f ms, full %.3f ms, ratio %.3f | %s" % (
    sys.argv[1], s["mean_ray_fraction"], s["mean_flip"], s["mean_reused_frame_gpu_ms"],
    s["mean_reference_gpu_ms"], s["reused_over_full_gpu_time"], passes))' "$1" || true
}
mkdir -p /tmp/bench-gpu-images

# Warm the clocks first: the GPU idles at a fraction of its boost clock.
step warm 60 "$RQR" bench --width "$W" --height "$H" --repeat 100 --json

# Frame reuse: burst-timed sequences against full renders of the same frames.
SEQ=(--width "$W" --height "$H" --frames "$FRAMES" --camera-path orbit:0.5 --backend bvh --reference --benchmark --json)
for scene in builtin kajiya; do
  s=()
  [ "$scene" = kajiya ] && s=("$KAJIYA")
  step "${scene}_reproject" 120 "$RQR" render "${s[@]}" "${SEQ[@]}" --reproject -o /tmp/bench-gpu-images/f.png
  summary "${scene}_reproject"
  step "${scene}_adaptive" 120 "$RQR" render "${s[@]}" "${SEQ[@]}" --reproject --adaptive-subsample --subsample-threshold 0.2 -o /tmp/bench-gpu-images/f.png
  summary "${scene}_adaptive"
  step "${scene}_frameless10" 120 "$RQR" render "${s[@]}" "${SEQ[@]}" --frameless 10 -o /tmp/bench-gpu-images/f.png
  summary "${scene}_frameless10"
done
# Frame loop: two compare runs (agreement), then 4K; wall times are in the step lines.
step compare_1 120 "$RQR" compare --width "$W" --height "$H" --repeat "$REPEAT" -o "$R/compare_1"
step compare_2 120 "$RQR" compare --width "$W" --height "$H" --repeat "$REPEAT" -o "$R/compare_2"
step compare_4k 180 "$RQR" compare --width "$W4" --height "$H4" --repeat "$REPEAT" -o "$R/compare_4k"
for c in compare_1 compare_2 compare_4k; do
  python3 - "$R/$c/report.json" "$c" <<'PY' || true
import json, sys
r = json.load(open(sys.argv[1]))
h = r["host"]
for b in r["backends"]:
    print("    %s %s: rt %.3f ms (%.3f-%.3f), hybrid %.3f ms; wall %.0f ms, GPU %.0f ms, host %.1f %%" % (
        sys.argv[2], b["backend"], b["rt"]["total_ms"], b["rt"]["total_ms_min"], b["rt"]["total_ms_max"],
        b["hybrid"]["total_ms"], h["wall_ms"], h["gpu_frames_ms"], 100 * h["host_overhead_share"]))
PY
done

# Visibility pass, compute rasterizer against the graphics pipeline.
step raster_graphics 120 "$RQR" compare --width "$W" --height "$H" --raster graphics --max-depth 1 --repeat "$REPEAT" -o "$R/raster_graphics"
step raster_compute 120 "$RQR" compare --width "$W" --height "$H" --raster compute --max-depth 1 --repeat "$REPEAT" -o "$R/raster_compute"

# BVH build: GPU against host BVH build, and the 1M mesh end to end.
step bvh_100k 120 "$RQR" bench "$MESHES/bumpy_sphere_100k.glb" $CAM --width "$W" --height "$H" --repeat "$REPEAT" --all-bvh-builds --json
step bvh_1m 180 "$RQR" bench "$MESHES/bumpy_sphere_1m.glb" $CAM --width "$W" --height "$H" --repeat "$REPEAT" --all-bvh-builds --json
step render_1m_gpu 60 "$RQR" render "$MESHES/bumpy_sphere_1m.glb" $CAM --width "$W" --height "$H" --backend bvh --bvh-build gpu -o /tmp/bench-gpu-images/m1.png
step render_1m_auto 60 "$RQR" render "$MESHES/bumpy_sphere_1m.glb" $CAM --width "$W" --height "$H" -o /tmp/bench-gpu-images/m1a.png

# Animation: animated frames (per-pass animation cost is in the JSON lines).
step anim_cesiumman 120 "$RQR" render assets/gltf/CesiumMan/CesiumMan.glb --width "$W" --height "$H" --frames "$FRAMES" --json -o /tmp/bench-gpu-images/cm.png

# Batch: `rqr batch` cold and warm against a process per view (assets/gltf, 2 views, 512²).
step batch 300 env RQR_BIN="$RQR" bash scripts/bench-batch.sh assets/gltf "${BATCH_VIEWS:-2}" "${BATCH_SIZE:-512}" "${BATCH_MODELS:-0}"
grep -E '^\||x views per minute' "$R/batch.out" || true

# Texture format: a first run in an empty cache measures (BC7 vs RGBA8 sampling among the rest).
step texture_measure 180 env RQR_NO_AUTOTUNE=0 XDG_CACHE_HOME="$R/autotune-cache" "$RQR" render --width 64 --height 64 -o /tmp/bench-gpu-images/tex.png
step texture_probe 30 env RQR_NO_AUTOTUNE=0 XDG_CACHE_HOME="$R/autotune-cache" "$RQR" probe --json
grep -E '"texture_(format|block_ms|rgba8_ms)' "$R/texture_probe.out" || true

find "$R" -name '*.png' -delete
pack
echo "done in $(( $(date +%s) - T0 ))s"
