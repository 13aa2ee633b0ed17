#!/usr/bin/env bash
# mpm-cli under mpirun (docs/distributed.md): shipped explicit scenes, shortened, run on one
# process and on 2 and 3 ranks; the ranks' snapshot pieces, joined by particle id, must equal
# the one-process snapshots bit for bit and VTK must read the distributed run.xmf as one
# dataset per step (scripts/compare_pieces.py). A TLMPM scene and a scene with checkpoints
# on 2 ranks must be refused with exit code 2 naming the key.
#
# Usage: scripts/mpi_cli_check.sh MPM_CLI (built with --features mpm-cli/mpi)
set -euo pipefail
cli=$(realpath "$1")
here=$(cd "$(dirname "$0")" && pwd)
py=${MPM_PYTHON:-python3}
mpirun=${MPIRUN:-mpirun --allow-run-as-root --oversubscribe}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

shorten() { # scene end_time -> shortened copy in $work
  sed "s/^end_time = .*/end_time = $2/" "$here/../scenes/$1.toml" > "$work/$1.toml"
}

for case in "dam_break_2d 0.1" "cube_water_column_2d 0.05" "jelly_cube_3d 0.02"; do
  set -- $case
  shorten "$1" "$2"
  "$cli" run "$work/$1.toml" --out "$work/$1-one" --quiet --threads 1
  for n in 2 3; do
    RAYON_NUM_THREADS=1 $mpirun -n "$n" "$cli" run "$work/$1.toml" --out "$work/$1-$n" --quiet
    echo "== $1 on $n ranks"
    "$py" "$here/compare_pieces.py" "$work/$1-one" "$work/$1-$n"
  done
done

refused() { # scene key
  set +e
  RAYON_NUM_THREADS=1 $mpirun -n 2 "$cli" run "$1" --out "$work/refused" --quiet 2> "$work/err"
  code=$?
  set -e
  if [ "$code" -ne 2 ] || ! grep -q "$2" "$work/err"; then
    echo "expected exit 2 naming $2 on 2 ranks, got $code:" >&2
    cat "$work/err" >&2
    exit 1
  fi
  echo "== refused on 2 ranks with exit 2: $2"
}
shorten tlmpm_cantilever_2d 0.01
refused "$work/tlmpm_cantilever_2d.toml" "simulation.solver"
{ cat "$work/dam_break_2d.toml"; printf '\n[checkpoint]\ninterval = 0.05\n'; } > "$work/ckpt.toml"
refused "$work/ckpt.toml" "checkpoint"
echo "mpm-cli under mpirun: all checks passed"
