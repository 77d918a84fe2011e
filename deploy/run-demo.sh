#!/usr/bin/env bash
# The main job on the embedded default: installs the dependencies, builds touchmend (release),
# lists the holes of the bundled sample (Spot with three holes cut) and repairs them all into
# ./touchmend-data/spot-repaired.obj. Any argument is passed to `touchmend fill` instead of --all.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
deploy/install-deps.sh --no-bench
cmake --workflow --preset release
touchmend=build/release/client/cli/touchmend
sample=deploy/samples/spot-holed.off
out_dir=${TOUCHMEND_DATA_DIR:-./touchmend-data}
mkdir -p "$out_dir"
echo "== holes of $sample"
"$touchmend" holes "$sample"
echo "== filling"
if (($# > 0)); then
  "$touchmend" fill "$sample" -o "$out_dir/spot-repaired.obj" "$@"
else
  "$touchmend" fill "$sample" -o "$out_dir/spot-repaired.obj" --all
fi
echo "== result"
"$touchmend" info "$out_dir/spot-repaired.obj"
