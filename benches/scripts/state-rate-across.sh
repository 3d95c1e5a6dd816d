#!/usr/bin/env bash
# The loop's state rate as a planner on "host B" sees it across the bridge, over mutual TLS
# (tls/ and quic/ endpoints) against plain TCP (--insecure), alternating runs on one machine: the product's own
# figures (the loop's summary: ticks / run_s; the planner's report: state_rate_hz).
# Host B is a folder whose config/iceoryx2.toml gives iceoryx2 another prefix, as in
# tests/tests/it/bridge.rs. Usage: benches/scripts/state-rate-across.sh [runs-per-link] [seconds]
# ["links"] (default "tcp tls quic"). A bridge or planner that does not exit cleanly is
# reported (exit status column).
# (release binaries: cargo build --release -p haptic-loop -p planner -p hrrtc-bridge).
set -euo pipefail
cd "$(dirname "$0")/../.."
runs="${1:-3}"
seconds="${2:-20}"
links="${3:-tcp tls quic}"
bin=target/release
work=$(mktemp -d /tmp/state-rate-XXXXXX)
trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$work"' EXIT
mkdir -p "$work/b/config"
echo "[global]
prefix = \"iox2_sr$$_\"" > "$work/b/config/iceoryx2.toml"
"$bin/hrrtc-bridge" certs --out "$work/certs" --name loop=127.0.0.1 --name planner >/dev/null
c="$work/certs"
echo "link  run  loop_hz  planner_state_hz  ratio   exit(bridge,planner)"
for i in $(seq 1 "$runs"); do
  for link in $links; do
    ns="sr_${link}_${i}_$$"
    port=$((17800 + i * 4))
    if [ "$link" = tcp ]; then
      a=(--listen "tcp/127.0.0.1:$port" --insecure)
      b=(--bridge-connect "tcp/127.0.0.1:$port" --bridge-insecure)
    else
      [ "$link" = quic ] && port=$((port + 2)) || port=$((port + 1))
      a=(--listen "$link/127.0.0.1:$port" --tls-ca "$c/ca.pem" --tls-cert "$c/loop.pem" --tls-key "$c/loop.key" --allow-peer planner)
      b=(--bridge-connect "$link/127.0.0.1:$port" --bridge-allow-peer loop --bridge-tls-ca "$c/ca.pem"
         --bridge-tls-cert "$c/planner.pem" --bridge-tls-key "$c/planner.key")
    fi
    "$bin/haptic-loop" run --namespace "$ns" --no-contact --scene silencer \
      --duration-s $((seconds + 8)) --summary-json "$work/loop.json" >/dev/null 2>&1 &
    loop=$!
    sleep 2
    "$bin/hrrtc-bridge" --side loop --namespace "$ns" "${a[@]}" >/dev/null 2>"$work/bridge.err" &
    bridge=$!
    sleep 1
    planner_rc=0
    rm -f "$work/planner.json"
    (cd "$work/b" && "$OLDPWD/$bin/planner" serve --namespace "$ns" --scene silencer \
      --duration-s "$seconds" --json "$work/planner.json" "${b[@]}" >/dev/null 2>"$work/planner.err") \
      || planner_rc=$?
    kill -TERM "$bridge" 2>/dev/null || true; bridge_rc=0; wait "$bridge" || bridge_rc=$?
    kill -TERM "$loop" 2>/dev/null || true; wait "$loop" || true
    python3 - "$link" "$i" "$work/loop.json" "$work/planner.json" "$bridge_rc,$planner_rc" <<'PY'
import json, sys
link, i, lp, pp, rcs = sys.argv[1:]
import os
l = json.load(open(lp))
loop_hz = l["ticks"] / l["run_s"]
if os.path.exists(pp):
    rate = json.load(open(pp))["state_rate_hz"]
    print(f"{link:<5} {i:<4} {loop_hz:7.1f}  {rate:16.1f}  {rate / min(loop_hz, 1000.0):.4f}  {rcs}")
else:
    print(f"{link:<5} {i:<4} {loop_hz:7.1f}  {'(no report)':>16}  {'-':>6}  {rcs}")
PY
  done
done
