# Sourced by the GPU benchmark scripts (scripts/bench-gpu*.sh): a fresh results folder $R,
# the log and archive under $OUT named after $NAME, and `step NAME TIMEOUT CMD...`, which runs
# a command with its own timeout, keeps its stdout/stderr in $R, prints one line with its exit
# status and wall time, and rewrites the archive (a run cut short still returns what it did).
OUT=${OUT:-/tmp/gpu-out}
mkdir -p "$OUT"
R=/tmp/$NAME-r
rm -rf "$R"
mkdir -p "$R"
exec > >(tee -a "$OUT/$NAME-log.txt") 2>&1
T0=$(date +%s)
pack() { tar czf "$OUT/$NAME-results.tgz" -C "$R" . 2>/dev/null; }
step() {
  local name=$1 to=$2
  shift 2
  local s
  s=$(date +%s.%N)
  timeout "$to" "$@" > "$R/$name.out" 2> "$R/$name.err"
  local rc=$?
  printf '=== %-20s rc=%-3s %7.2fs wall [t+%ss] %s\n' "$name" "$rc" \
    "$(awk -v a="$(date +%s.%N)" -v b="$s" 'BEGIN{print a-b}')" "$(( $(date +%s) - T0 ))" "$*"
  [ "$rc" != 0 ] && tail -c 800 "$R/$name.err"
  pack
}
