#!/usr/bin/env bash
# Compute-BVH primary-ray throughput against Embree on the same cores, measured moments apart.
#
# The 2-core VMs this project runs on change speed from one minute to the next (other tenants'
# load on the host), so an absolute Mrays/s figure drifts by up to 1.6x between runs. Embree
# traced right before each `rqr bench` run gives a reference measured under the same conditions;
# the issue's target is half of Embree. Embree here is Embree 2.17 through `embreex`
# (rtcIntersect1 per ray, one process per core), the closest thing PyPI offers.
#
# usage: scripts/bench-vs-embree.sh [RUNS] [MESH]   (default: 6 runs, bumpy_sphere_100k.glb)
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/env.sh
runs=${1:-6}
mesh=${2:-../shared/meshes/bumpy_sphere_100k.glb}
venv=target/embree-venv
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet embreex trimesh numpy
fi
cargo build --release --quiet
echo "run  embree_Mrays/s  rqr_bvh_primary_Mrays/s  rqr/embree"
for i in $(seq 1 "$runs"); do
    embree=$("$venv/bin/python" scripts/embree_primary.py "$mesh" 512 2.5 45 | awk '{print $2}')
    rqr=$(./target/release/rqr bench "$mesh" --look-from 0,0,2.5 --look-at 0,0,0 --fov 45 \
        --backend bvh --repeat 5 --json 2>/dev/null |
        python3 -c "import json,sys; print('%.3f' % json.load(sys.stdin)['backends'][0]['primary']['mrays_per_s'])")
    python3 -c "print('%3d  %14.3f  %23.3f  %10.2f' % ($i, $embree, $rqr, $rqr / $embree))"
done
