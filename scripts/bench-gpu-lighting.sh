#!/usr/bin/env bash
# GPU benchmarks of the lighting techniques in one run of about 5 minutes on an NVIDIA H200
# (after the machine starts): environment-map preparation (first time and from the cache),
# the environment's lookup cost in a Whitted frame, a 1-spp distributed frame against the
# Whitted frame, and the denoiser's passes, all at 1920x1080 with GPU timestamps. Run from the
# project root on the GPU machine, with .gpu/ prepared as for scripts/bench-gpu.sh and
# DamagedHelmet.glb copied into it (cp path/to/DamagedHelmet.glb .gpu/):
#
#   bash scripts/bench-gpu-lighting.sh
#
# Results: $OUT/bench-gpu-lighting-log.txt (a summary line per measurement) and
# $OUT/bench-gpu-lighting-results.tgz (every command's stdout/stderr). Each step has its own
# timeout and the archive is rewritten after every step, so a run cut short still returns what
# it finished.
#
# Dry run on a development machine (lavapipe, tiny sizes, no .gpu/ needed):
#   DRY_RUN=1 HELMET=path/to/DamagedHelmet.glb bash scripts/bench-gpu-lighting.sh
#
# Measured:
#   prepare       `environment_prepare` of `rqr render --json` for sunrise.hdr (1024x512): in an
#                 empty cache twice, then from the cache (targets: <= 20 ms on the GPU).
#   lookup        `rqr compare --repeat N` of the built-in scene with and without studio.hdr,
#                 alternated 3 times: rt and hybrid frame GPU ms (target: <= 3 % more).
#   distributed   1-spp distributed against Whitted frames at depth 3, bursts alternated 3
#                 times: the built-in scene with --light-radius 0.1 and DamagedHelmet under
#                 sunrise.hdr, rt and hybrid (targets: <= 2x, a distributed frame <= 3 ms).
#   denoise       the denoiser's passes (`denoise *`) against the ray-tracing pass, still and
#                 orbiting camera (target: <= 2 ms).
set -u
NAME=bench-gpu-lighting
. scripts/bench-gpu-steps.sh
mkdir -p "$R/images"
if [ -n "${DRY_RUN:-}" ]; then
  . scripts/env.sh
  RQR=${RQR:-target/debug/rqr}; W=${W:-96}; H=${H:-64}
  HELMET=${HELMET:-../shared/gltf/DamagedHelmet/DamagedHelmet.glb}
  FRAMES=${FRAMES:-4}; REPEAT=${REPEAT:-3}
else
  . .gpu/nvidia-env.sh
  nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv,noheader || true
  RQR=/tmp/rqr; W=1920; H=1080; HELMET=${HELMET:-.gpu/DamagedHelmet.glb}
  FRAMES=40; REPEAT=50
fi
ENV_DIR=assets/environments
# The preparation's caches stay out of the results archive (a prepared map is megabytes).
CACHES=/tmp/bench-gpu-lighting-caches
rm -rf "$CACHES"
# The JSON document a command printed (render prints one object; sequences end with a line).
json_of() { python3 -c '
import json, sys
text = open(sys.argv[1]).read().strip()
try:
    doc = json.loads(text)
except ValueError:
    doc = json.loads(text.splitlines()[-1])
print(json.dumps(doc))' "$R/$1.out"; }

# Warm the clocks first: the GPU idles at a fraction of its boost clock.
step warm 60 "$RQR" bench --width "$W" --height "$H" --repeat 100 --json

# Preparation: two empty caches (the first also compiles the pipelines), then the cache.
for run in cold_1 cold_2 cached; do
  cache="$CACHES/$run"
  [ "$run" = cached ] && cache="$CACHES/cold_2"
  step "prepare_$run" 60 env RQR_NO_AUTOTUNE=1 RQR_CACHE_DIR="$cache" "$RQR" render \
    --environment "$ENV_DIR/sunrise.hdr" --width 64 --height 64 --json -o "$R/images/p.png"
  json_of "prepare_$run" | python3 -c '
import json, sys
p = json.load(sys.stdin)["environment_prepare"]
print("    prepare %s: total %.2f ms, GPU %.2f ms, host mips %.2f ms, cached %s" % (
    sys.argv[1], p["total_ms"], p["gpu_ms"], p["mips_ms"], p["cached"]))' "$run" || true
done

# Lookup cost: the same compare with and without a map, alternated.
for round in 1 2 3; do
  step "lookup_flat_$round" 120 "$RQR" compare --width "$W" --height "$H" --repeat "$REPEAT" -o "$R/lookup_flat_$round"
  step "lookup_env_$round" 120 "$RQR" compare --width "$W" --height "$H" --repeat "$REPEAT" \
    --environment "$ENV_DIR/studio.hdr" -o "$R/lookup_env_$round"
  python3 - "$R/lookup_flat_$round/report.json" "$R/lookup_env_$round/report.json" "$round" <<'PY' || true
import json, sys
flat, env = (json.load(open(p)) for p in sys.argv[1:3])
for bf, be in zip(flat["backends"], env["backends"]):
    for path in ("rt", "hybrid"):
        f, e = bf[path]["total_ms"], be[path]["total_ms"]
        print("    lookup round %s %s %s: %.3f -> %.3f ms (%+.1f %%)" % (
            sys.argv[3], bf["backend"], path, f, e, 100 * (e / f - 1)))
PY
done

# Distributed against Whitted: bursts of FRAMES frames, the two models alternated.
frame_ms() { json_of "$1" | python3 -c '
import json, sys
s = json.load(sys.stdin)["summary"]
print(s["frame_gpu_ms"]["median"])'; }
for scene in builtin helmet; do
  if [ "$scene" = builtin ]; then args=(--light-radius 0.1); else args=("$HELMET" --environment "$ENV_DIR/sunrise.hdr"); fi
  [ "$scene" = helmet ] && [ ! -f "$HELMET" ] && { echo "    no $HELMET: helmet skipped"; continue; }
  for mode in rt hybrid; do
    for round in 1 2 3; do
      for shading in whitted distributed; do
        step "dist_${scene}_${mode}_${shading}_$round" 120 "$RQR" render "${args[@]}" --mode "$mode" \
          --shading "$shading" --max-depth 3 --width "$W" --height "$H" --frames "$FRAMES" \
          --benchmark --burst "$FRAMES" --json -o "$R/images/d.png"
      done
      w=$(frame_ms "dist_${scene}_${mode}_whitted_$round" 2>/dev/null || echo nan)
      d=$(frame_ms "dist_${scene}_${mode}_distributed_$round" 2>/dev/null || echo nan)
      python3 -c 'import sys; s, m, r, w, d = sys.argv[1:]; w, d = float(w), float(d)
print("    distributed %s %s round %s: %.3f / %.3f ms = %.2fx" % (s, m, r, d, w, d / w))' \
        "$scene" "$mode" "$round" "$w" "$d" || true
    done
  done
done

# Denoiser: its passes against the ray-tracing pass, still and orbiting.
for path in static orbit:0.5; do
  name="denoise_${path%%:*}"
  step "$name" 180 "$RQR" render --mode rt --shading distributed --denoise svgf --light-radius 0.1 \
    --width "$W" --height "$H" --frames "$FRAMES" --camera-path "$path" --benchmark --burst "$FRAMES" \
    --json -o "$R/images/n.png"
  json_of "$name" | python3 -c '
import json, sys
s = json.load(sys.stdin)["summary"]
p = {x["name"]: x["median"] for x in s["passes"]}
dn = sum(v for k, v in p.items() if k.startswith("denoise"))
print("    %s: denoiser %.3f ms (%s), rt %.3f ms, ratio %.2f; frame %.3f ms" % (sys.argv[1], dn,
    ", ".join("%s %.3f" % (k, v) for k, v in p.items() if k.startswith("denoise")), p["rt"],
    dn / p["rt"], s["frame_gpu_ms"]["median"]))' "$name" || true
done

rm -rf "$R/images"
pack
echo "done in $(( $(date +%s) - T0 ))s"
