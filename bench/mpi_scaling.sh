#!/usr/bin/env bash
# Issue 9: wall time of `fesim benchmark` at 1, 2 and 4 MPI ranks (one thread per rank), each
# from an empty output directory, and the single-process run with all cores for comparison.
# Usage: bench/mpi_scaling.sh [--default] [RANKS...]   (default: the quick study; ranks 1 2 4)
# Prints one line per run: ranks, wall s, CPU s, load before; leaves results in /tmp/fesim-mpi-*.
# More ranks than cores run oversubscribed (--oversubscribe), which the output says.
set -euo pipefail
cd "$(dirname "$0")/.."
mode="--quick"
if [ "${1:-}" = "--default" ]; then mode=""; shift; fi
ranks=("$@")
[ ${#ranks[@]} -eq 0 ] && ranks=(1 2 4)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
cores=$(nproc)
name=${mode:+quick}
name=${name:-default}
echo "study: $name; cores: $cores; fesim: $(build/bin/fesim --version)"
for r in "${ranks[@]}"; do
  out="/tmp/fesim-mpi-$name-$r"
  rm -rf "$out"
  load=$(cut -d' ' -f1 /proc/loadavg)
  over=""
  [ "$r" -gt "$cores" ] && over=" (oversubscribed: $r ranks on $cores cores)"
  /usr/bin/time -f "%e %U %S" -o /tmp/fesim-mpi-time \
    mpirun -np "$r" --oversubscribe build/bin/fesim benchmark scenarios/default_study.yaml \
    $mode --threads 1 --out "$out" >/dev/null 2>&1
  read -r wall user sys </tmp/fesim-mpi-time
  cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { print u + s }')
  echo "ranks $r: wall ${wall} s, CPU ${cpu} s, load before ${load}${over}"
done
