#!/usr/bin/env bash
# run_nats_viewer.sh - the viewer over NATS in headless Chromium (nats_viewer.mjs): two nats-server
# nodes clustered on loopback, each with a WebSocket listener; meshsteerd publishes to node 1 and
# serves the page; the page reads from node 2 (?nats=ws://127.0.0.1:WS2&encoding=int16). Node 2 is then killed and
# started again on the same ports, and the viewer must come back by itself. Every process started
# here is killed on exit, whatever the outcome.
# Usage: run_nats_viewer.sh MESHSTEERD MAKE_MODEL SCREENSHOT.png        Exit 77 = skipped.
set -euo pipefail
meshsteerd=$1 make_model=$2 shot=$3
here=$(cd "$(dirname "$0")" && pwd)
web=${MESHSTEER_SRC:-$here/../../..}/clients/web
nats_server=${NATS_SERVER:-/usr/sbin/nats-server}
command -v node >/dev/null || { echo "skip: node not installed"; exit 77; }
[ -x "$nats_server" ] || { echo "skip: nats-server not installed"; exit 77; }
[ -x "${CHROMIUM:-/usr/bin/chromium}" ] || { echo "skip: chromium not installed"; exit 77; }
[ -f "$web/node_modules/.meshsteer/nats-core.js" ] && [ -d "$web/node_modules/playwright-core" ] ||
    { echo "skip: run 'npm ci' in clients/web (scripts/run.sh does)"; exit 77; }

dir=$(mktemp -d "${MESHSTEER_BUILD:-/tmp}/e2e-nats-XXXXXX")
pids=()
cleanup() {
    for p in "${pids[@]}" $(cat "$dir"/node*.pid 2>/dev/null); do kill -9 "$p" 2>/dev/null || true; done
    wait 2>/dev/null || true
    rm -rf "$dir"
}
trap cleanup EXIT
"$make_model" "$dir" >/dev/null

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
wait_port() { for _ in $(seq 200); do (exec 3<>/dev/tcp/127.0.0.1/"$1") 2>/dev/null && return 0; sleep 0.05; done; return 1; }
for i in 1 2; do
    eval "port$i=$(free_port) ws$i=$(free_port) route$i=$(free_port)"
done
for i in 1 2; do
    other=$((3 - i))
    p=port$i w=ws$i r=route$i o=route$other
    cat >"$dir/node$i.conf" <<EOC
server_name: node$i
listen: 127.0.0.1:${!p}
websocket { listen: "127.0.0.1:${!w}", no_tls: true }
cluster { name: meshsteer-e2e, listen: 127.0.0.1:${!r}, routes: [ nats-route://127.0.0.1:${!o} ] }
EOC
done
# start.sh I: starts node I in the background (its pid in node I.pid), waits for its client port
cat >"$dir/start.sh" <<EOS
#!/usr/bin/env bash
"$nats_server" -c "$dir/node\$1.conf" >>"$dir/node\$1.log" 2>&1 &
echo \$! >"$dir/node\$1.pid"
port=\$(sed -n 's/^listen: 127.0.0.1:\([0-9]*\)$/\1/p' "$dir/node\$1.conf")
for _ in \$(seq 200); do (exec 3<>/dev/tcp/127.0.0.1/\$port) 2>/dev/null && exit 0; sleep 0.05; done
cat "$dir/node\$1.log" >&2
exit 1
EOS
chmod +x "$dir/start.sh"
"$dir/start.sh" 1
"$dir/start.sh" 2

"$meshsteerd" --model "$dir/example.msm" --source "replay:$dir/trot.csv?loop=1" \
    --listen 127.0.0.1:0 --web-root "$web" --publish "nats://127.0.0.1:$port1" \
    2>"$dir/daemon.log" </dev/null >/dev/null &
pids+=($!)
port=
for _ in $(seq 100); do
    port=$(sed -n 's|.*listening on http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$dir/daemon.log")
    [ -n "$port" ] && break
    sleep 0.1
done
[ -n "$port" ] || { cat "$dir/daemon.log" >&2; exit 1; }
export MESHSTEER_WEB_DIR=$web
export MESHSTEER_NATS_RESTART_CMD="kill -9 \$(cat '$dir/node2.pid'); sleep 1; '$dir/start.sh' 2"
status=0
node "$here/nats_viewer.mjs" "http://127.0.0.1:$port/?nats=ws://127.0.0.1:$ws2&encoding=int16" "$shot" ||
    status=$?
[ $status -eq 0 ] || { echo "---- daemon log"; cat "$dir/daemon.log"; for i in 1 2; do echo "---- node$i"; cat "$dir/node$i.log"; done; } >&2
exit $status
