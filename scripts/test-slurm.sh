#!/usr/bin/env bash
# `rqr batch --shard auto` under a real Slurm: starts a single-node cluster on localhost
# (Debian's slurm-wlm and munge; installed with apt-get when missing, so run it as root in a
# throw-away machine or container), then
#   1. renders a manifest of 24 jobs x 4 views (96 views) in one process, for reference;
#   2. `sbatch --array=0-3 --wait` of `rqr batch --shard auto`: the union of the four shards'
#      outputs must be byte-identical to the reference;
#   3. submits the array again into a fresh directory, cancels it once shard 0 has finished
#      its first job, resubmits it: finished jobs must be skipped, and the outputs must again
#      be byte-identical to the reference. The kill cannot race the renders: during that
#      run, shard 0's second scene is a named pipe nobody writes, so the shard's loader waits
#      on it until the kill (without the pipe, a fast machine can finish all 6 jobs before
#      scancel lands).
# Stops the daemons it started on exit. Prints PASS or FAIL lines; exits 1 on any failure.
# Usage: scripts/test-slurm.sh   (RQR_BIN=path to use a built binary; default target/debug/rqr)
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/env.sh
rqr=$(realpath "${RQR_BIN:-target/debug/rqr}")
[ -x "$rqr" ] || { echo "no rqr binary at $rqr (cargo build first)"; exit 1; }
if ! command -v slurmctld > /dev/null || ! command -v munged > /dev/null; then
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q slurm-wlm munge > /dev/null
fi
started=$(date +%s)
work=$(mktemp -d /tmp/rqr-slurm.XXXXXX)
host=$(hostname -s)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2> /dev/null || true; done
}
trap cleanup EXIT

# munge: a key of its own, a socket in the work directory.
mkdir -p "$work/munge"
dd if=/dev/urandom bs=1 count=1024 of="$work/munge/munge.key" status=none
chmod 400 "$work/munge/munge.key"
chown -R munge:munge "$work/munge" 2> /dev/null || true
chmod 755 "$work"
sock=$work/munge/munge.socket
runuser -u munge -- munged --key-file="$work/munge/munge.key" --socket="$sock" \
  --pid-file="$work/munge/munged.pid" --log-file="$work/munge/munged.log" \
  --seed-file="$work/munge/munged.seed" --force
pids+=("$(cat "$work/munge/munged.pid")")

mkdir -p "$work/state" "$work/spool"
cat > "$work/slurm.conf" << EOF
ClusterName=rqrtest
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
AuthInfo=socket=$sock
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$work/slurm.conf
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do
  [ -f "$work/slurmctld.pid" ] && [ -f "$work/slurmd.pid" ] && break
  sleep 0.5
done
pids+=("$(cat "$work/slurmctld.pid")" "$(cat "$work/slurmd.pid")")
for _ in $(seq 60); do
  sinfo -h -o %T 2> /dev/null | grep -q idle && break
  sleep 1
done
sinfo -h -o %T | grep -q idle || { echo "FAIL: the node did not come up"; tail "$work"/*.log; exit 1; }

# The manifest: 24 jobs x 4 views of the repository's small models.
mkdir -p "$work/data"
for m in Box BoxTextured AnimatedMorphCube AttenuationTest; do
  glb=$(ls assets/gltf/$m/*.glb | head -1)
  cp "$glb" "$work/data/$m.glb"
done
{
  echo '{"defaults": {"width": 128, "height": 128, "cameras": {"orbit": {"n": 4, "elevation_deg": [0, 30], "seed": 5}}}}'
  k=0
  for r in 0 1 2 3 4 5; do
    for m in Box BoxTextured AnimatedMorphCube AttenuationTest; do
      scene=$m.glb
      # Line 8 is shard 0's second job (line 0 holds the defaults): a file of its own, which
      # the kill below swaps for a pipe.
      [ "$k" -eq 7 ] && scene=held.glb
      echo "{\"id\": \"$m-$r\", \"scene\": \"$scene\", \"cameras\": {\"orbit\": {\"n\": 4, \"elevation_deg\": [0, 30], \"seed\": $k}}}"
      k=$((k + 1))
    done
  done
} > "$work/data/manifest.jsonl"
cp "$work/data/AttenuationTest.glb" "$work/data/held.glb"
manifest=$work/data/manifest.jsonl


failures=0
check() { # description command...
  if "${@:2}"; then echo "PASS: $1"; else echo "FAIL: $1"; failures=$((failures + 1)); fi
}
same_outputs() { diff -r -q --exclude='results-*' "$work/single" "$1" > /dev/null; }

"$rqr" batch "$manifest" --out "$work/single" > "$work/single.log" 2>&1 || { echo "FAIL: reference run"; tail "$work/single.log"; exit 1; }
views=$(find "$work/single" -name '*.png' | wc -l)
check "reference run rendered $views views (>= 40)" test "$views" -ge 40

t0=$(date +%s)
sbatch --array=0-3 --wait -o "$work/array-%a.out" \
  --wrap "$rqr batch $manifest --out $work/sharded --shard auto" > /dev/null || true
array_s=$(($(date +%s) - t0))
check "sbatch --array=0-3 wrote results-{0..3}-of-4.jsonl" \
  test "$(ls "$work/sharded"/results-*-of-4.jsonl 2> /dev/null | wc -l)" -eq 4
check "union of 4 shards is byte-identical to one process ($array_s s)" same_outputs "$work/sharded"

# Kill midway and resubmit. While the killed array runs, shard 0's second scene is a pipe
# with no writer: the shard renders its first job, then its loader blocks until the kill.
# --time bounds the array should scancel fail.
mv "$work/data/held.glb" "$work/held.glb"
mkfifo "$work/data/held.glb"
job=$(sbatch --parsable --array=0-3 --time=3 -o "$work/killed-%a.out" \
  --wrap "$rqr batch $manifest --out $work/resumed --shard auto")
for _ in $(seq 600); do
  [ -s "$work/resumed/results-0-of-4.jsonl" ] && break
  sleep 0.1
done
sleep 1 # shard 0 now waits on the pipe; give shards 1-3 a moment more of work to lose
scancel "$job"
for _ in $(seq 60); do
  [ -z "$(squeue -h -j "$job" 2> /dev/null)" ] && break
  sleep 0.5
done
rm "$work/data/held.glb"
mv "$work/held.glb" "$work/data/held.glb"
before=$(grep -c '"status":"ok"' "$work/resumed/results-0-of-4.jsonl" 2> /dev/null || true)
sbatch --array=0-3 --wait -o "$work/resubmitted-%a.out" \
  --wrap "$rqr batch $manifest --out $work/resumed --shard auto" > /dev/null || true
skipped=$(cat "$work/resumed"/results-*-of-4.jsonl | grep -c '"status":"skipped"' || true)
echo "killed after shard 0 finished ${before:-0} of its 6 jobs; the resubmission skipped $skipped jobs"
check "the kill landed after shard 0's first job" test "${before:-0}" -eq 1
check "the resubmission skipped the finished jobs" test "$skipped" -ge 1
check "killed + resubmitted outputs are byte-identical to one process" same_outputs "$work/resumed"
echo "slurm test: $(($(date +%s) - started)) s, work directory $work"
[ "$failures" -eq 0 ]
