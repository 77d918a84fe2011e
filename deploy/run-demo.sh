#!/usr/bin/env bash
# The main job on the embedded default: installs the dependencies, builds touchmend (release),
# starts a touchmend-server on loopback with its store in ./touchmend-data/server, and repairs
# the bundled sample (Spot with three holes cut) through it into
# ./touchmend-data/spot-repaired.obj. Any argument is passed to `touchmend fill` instead of --all.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
deploy/install-deps.sh --no-bench
cmake --workflow --preset release
bin=build/release
touchmend=$bin/client/cli/touchmend
sample=deploy/samples/spot-holed.off
out_dir=${TOUCHMEND_DATA_DIR:-./touchmend-data}
mkdir -p "$out_dir"

echo "== starting touchmend-server (store in $out_dir/server, log in $out_dir/server.log)"
rm -f "$out_dir/server.port"
"$bin/server/touchmend-server" --listen 127.0.0.1:0 --data-dir "$out_dir/server" \
  --port-file "$out_dir/server.port" 2>"$out_dir/server.log" &
server_pid=$!
trap 'kill "$server_pid" 2>/dev/null || true; wait "$server_pid" 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  [[ -s "$out_dir/server.port" ]] && break
  kill -0 "$server_pid" 2>/dev/null || { cat "$out_dir/server.log"; exit 1; }
  sleep 0.1
done
server="127.0.0.1:$(head -1 "$out_dir/server.port")"

echo "== holes of $sample (on $server)"
"$touchmend" --server "$server" holes "$sample"
echo "== filling (on $server)"
if (($# > 0)); then
  "$touchmend" --server "$server" fill "$sample" -o "$out_dir/spot-repaired.obj" "$@"
else
  "$touchmend" --server "$server" fill "$sample" -o "$out_dir/spot-repaired.obj" --all
fi
echo "== result"
"$touchmend" info "$out_dir/spot-repaired.obj"
