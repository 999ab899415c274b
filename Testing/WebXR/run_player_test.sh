#!/usr/bin/env bash
# Runs the WebXR player end to end: starts `holovolume --serve` on a free port with the head
# MRI, points test_player.mjs (headless Chromium, iwer as the headset) at the URL it prints,
# stops the server and checks that the server received the page's poses.
#   run_player_test.sh HOLOVOLUME_BINARY MODE CODEC [SCREENSHOT [SERVER ARGUMENTS...]]
# With --camera among the server's arguments it also checks that the live light was followed:
# the lighting chain ran and the camera's lamp replaced the radiance map while streaming.
set -euo pipefail
holovolume="$1"
mode="$2"
codec="$3"
screenshot="${4:-}"
shift $(( $# < 4 ? $# : 4 ))
server_arguments=("$@")
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
log="$(mktemp)"
trap 'kill "$server" 2>/dev/null || true; rm -f "$log"' EXIT

"$holovolume" --serve --port 0 --codec "$codec" --eye-size 160x104 --serve-seconds 170 \
  "${server_arguments[@]}" >"$log" 2>&1 &
server=$!
url=""
for _ in $(seq 1 600); do
  url="$(grep -o 'http://127\.0\.0\.1:[0-9]*/?token=[0-9a-f]*' "$log" | head -n 1 || true)"
  [ -n "$url" ] && break
  kill -0 "$server" 2>/dev/null || break
  sleep 0.1
done
if [ -z "$url" ]; then
  echo "FAIL: the server printed no URL"
  cat "$log"
  exit 1
fi
echo "server: $url"
status=0
node "$here/test_player.mjs" --url "$url" --mode "$mode" --codec "$codec" \
  ${screenshot:+--screenshot "$screenshot"} || status=$?
kill -TERM "$server"
server_status=0
wait "$server" || server_status=$?
echo "--- server log"
cat "$log"
# SIGTERM asks the server to stop after the frame it is on: it exits with 0.
if [ "$server_status" -ne 0 ]; then
  echo "FAIL: the server exited with status $server_status"
  status=1
fi
# The server's own account: it received poses (the page's) and rendered frames for them.
if ! grep -Eq 'Served [1-9][0-9]* frames to [1-9][0-9]* poses' "$log"; then
  echo "FAIL: the server did not report frames rendered for received poses"
  status=1
fi
if [[ " ${server_arguments[*]} " == *" --camera "* ]]; then
  if ! grep -Eq 'the light changed: camera frame [0-9]+, T 0\.[1-9]' "$log" ||
    ! grep -Eq 'Live lighting: [1-9][0-9]* steps of the chain' "$log"; then
    echo "FAIL: the server did not follow the camera's light (no replaced radiance map)"
    status=1
  fi
  # Unless the stream is raw, the denoiser must have been given the change (T > 0) for a
  # published frame, so that it relit its history rather than averaged the old light in.
  if [[ " ${server_arguments[*]} " != *" --no-denoiser "* ]] &&
    ! grep -Eq 'and [1-9][0-9]* published frames gave the denoiser the change' "$log"; then
    echo "FAIL: no published frame gave the denoiser the change of light"
    status=1
  fi
fi
exit "$status"
