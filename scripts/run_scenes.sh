#!/usr/bin/env bash
# Runs every scene in scenes/ with its end time cut to END (default 0.1 s; TLMPM scenes keep
# theirs when shorter) into OUT/<scene>/, with the mpm-cli binary BIN, on THREADS threads.
# Pair with scripts/hash_outputs.py --compare to check that a change keeps outputs bitwise.
#   scripts/run_scenes.sh BIN OUT [END] [THREADS]
set -euo pipefail
bin=$1; out=$2; end=${3:-0.1}; threads=${4:-2}
cd "$(dirname "$0")/.."
tmp=$(mktemp -d)
ln -s "$PWD/scenes/meshes" "$tmp/meshes"
mkdir -p "$out"
for s in scenes/*.toml; do
  name=$(basename "$s" .toml)
  # (scenes read their meshes by paths relative to the scene file: the copy sees scenes/meshes)
  sed -E "s/^end_time *= *[0-9.eE+-]+/end_time = $end/" "$s" > "$tmp/$name.toml"
  start=$(date +%s%N)
  if "$bin" run "$tmp/$name.toml" --out "$out/$name" --threads "$threads" --quiet >/dev/null 2>"$out/$name.log"; then
    st=ok
  else
    st="exit $?"
  fi
  ms=$(( ($(date +%s%N) - start) / 1000000 ))
  printf '%-40s %s %d.%03d s\n' "$name" "$st" $((ms / 1000)) $((ms % 1000))
done
rm -rf "$tmp"
