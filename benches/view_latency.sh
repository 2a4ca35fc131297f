#!/usr/bin/env bash
# Input-to-screen latency of the tool sphere, frame rate and steps/s of `phyxel view`
# under Xvfb (Mesa's software OpenGL), driven by xdotool: the tool is brought up (`t`)
# and the pointer circles over the image for SECONDS. Prints the viewer's JSON line
# (`tool_latency`: from the UI pass that sent a pointer move to the end of the first UI
# pass drawing a step taken after it; frames/s; steps/s).
#
# Usage: benches/view_latency.sh [SCENE] [SECONDS]   (needs xvfb-run and xdotool)
set -euo pipefail
scene=${1:-two-spheres}
seconds=${2:-10}
bin=${PHYXEL_BIN:-target/release/phyxel}
xvfb-run -a -s "-screen 0 1920x1080x24" bash -c '
  "$0" view "$1" --size 1280x720 --json --seconds "$2" > /tmp/phyxel-view-latency.json &
  viewer=$!
  for _ in $(seq 50); do
    w=$(xdotool search --name "phyxel view" 2>/dev/null | head -1) && [ -n "$w" ] && break
    sleep 0.1
  done
  sleep 1
  xdotool windowfocus --sync "$w" 2>/dev/null || true
  xdotool mousemove --window "$w" 640 360
  xdotool key t
  end=$((SECONDS + $2 - 2))
  a=0
  while [ $SECONDS -lt $end ]; do
    x=$(awk -v a=$a "BEGIN { printf \"%d\", 640 + 200 * cos(a / 20) }")
    y=$(awk -v a=$a "BEGIN { printf \"%d\", 360 + 120 * sin(a / 20) }")
    xdotool mousemove --window "$w" "$x" "$y"
    a=$((a + 1))
    sleep 0.02
  done
  wait $viewer
' "$bin" "$scene" "$seconds"
cat /tmp/phyxel-view-latency.json
