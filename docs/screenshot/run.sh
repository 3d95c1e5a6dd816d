#!/usr/bin/env bash
# Take docs/view-screenshot.png: haptic-loop demo + planner view + a locally built Lichtblick
# web app in headless Chromium (shoot.cjs). Not part of the build or the tests.
#
#   LICHTBLICK_WEB  a built Lichtblick web app (its `web/.webpack` after `yarn web:build:prod`)
#   NODE_PATH       a node_modules holding playwright-core
#   BIN             haptic-loop and planner binaries            [target/release]
#   OUT             the PNG                                     [docs/view-screenshot.png]
#   WAIT_S          seconds in the viewer before the shot       [15]
#   M_PER_N         force-arrow scale for the view, m/N         [0.005]
# Also passed on to shoot.cjs: CHROMIUM, GL, WIDTH, HEIGHT.
set -euo pipefail
cd "$(dirname "$0")/../.."
: "${LICHTBLICK_WEB:?set LICHTBLICK_WEB to a built Lichtblick web app (web/.webpack)}"
BIN=${BIN:-target/release}
OUT=${OUT:-docs/view-screenshot.png}
NS=shot-$$
HTTP_PORT=${HTTP_PORT:-8080}
WS_PORT=${WS_PORT:-8765}

pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT

python3 -m http.server "$HTTP_PORT" --bind 127.0.0.1 --directory "$LICHTBLICK_WEB" >/dev/null 2>&1 &
pids+=($!)
"$BIN/haptic-loop" demo --namespace "$NS" --min-run-s 120 --after-solve-s 120 >/tmp/"$NS"-demo.log 2>&1 &
pids+=($!)
sleep 1
"$BIN/planner" view --namespace "$NS" --scene wall-hole --port "$WS_PORT" \
  --m-per-n "${M_PER_N:-0.005}" --duration-s 120 >/tmp/"$NS"-view.log 2>&1 &
pids+=($!)
sleep 1

LICHTBLICK_URL="http://127.0.0.1:$HTTP_PORT/" WS_URL="ws://127.0.0.1:$WS_PORT" OUT="$OUT" \
  WAIT_S="${WAIT_S:-15}" node docs/screenshot/shoot.cjs
grep -E "solved|misses" /tmp/"$NS"-demo.log | tail -n 1 || true
