#!/usr/bin/env bash
# Steps/s of `phyxel view` stepping flat out (--speed 0) while the window draws at
# 1280x720 under Xvfb (Mesa's software OpenGL), against headless `phyxel run` over the
# same number of steps on 1 and 2 threads; the three runs alternate, ROUNDS times, and
# the medians are printed with the window's frames/s.
#
# Usage: benches/view_speed.sh [SCENE] [SECONDS] [ROUNDS]   (needs xvfb-run)
set -euo pipefail
scene=${1:-two-spheres}
seconds=${2:-10}
rounds=${3:-3}
bin=${PHYXEL_BIN:-target/release/phyxel}
rows=()
for _ in $(seq "$rounds"); do
  view=$(xvfb-run -a -s "-screen 0 1920x1080x24" "$bin" view "$scene" --speed 0 --json \
    --seconds "$seconds" --size 1280x720)
  steps=$(python3 -c 'import json,sys; print(json.loads(sys.argv[1])["steps"])' "$view")
  one=$(RAYON_NUM_THREADS=1 "$bin" run "$scene" --steps "$steps" --json 2>/dev/null)
  two=$(RAYON_NUM_THREADS=2 "$bin" run "$scene" --steps "$steps" --json 2>/dev/null)
  rows+=("$(python3 -c '
import json, sys
v, a, b = (json.loads(x) for x in sys.argv[1:4])
print(v["steps"], v["steps_per_second"], v["frames_per_second"], v["real_time"],
      a["steps_per_second"], b["steps_per_second"])' "$view" "$one" "$two")")
done
printf '%s\n' "${rows[@]}" | python3 -c '
import statistics, sys
rows = [list(map(float, l.split())) for l in sys.stdin if l.strip()]
m = [statistics.median(c) for c in zip(*rows)]
print(f"steps {m[0]:.0f}  view {m[1]:.0f} steps/s ({m[3]:.2f}x real time, {m[2]:.1f} frames/s)  "
      f"headless 1 thread {m[4]:.0f}  2 threads {m[5]:.0f}  "
      f"view/headless: {m[1]/m[4]:.2f} (1 thread), {m[1]/m[5]:.2f} (2 threads)")'
