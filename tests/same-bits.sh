#!/usr/bin/env bash
# Same bits: runs every built-in scene with `run --json` on two phyxel binaries and
# compares the summaries with wall-clock keys removed (wall_seconds, steps_per_second,
# phase_seconds), the same for two scenes on the other backends, plus the binary PLY
# frames of one scene (the resampling path runs only when frames are written). Used to show that a refactor changes no result.
#
#   tests/same-bits.sh OLD_BINARY NEW_BINARY
#
# Exits 0 when every summary and frame is identical, 1 otherwise (the differing scenes
# are listed).
set -euo pipefail
old=${1:?usage: same-bits.sh OLD_BINARY NEW_BINARY}
new=${2:?usage: same-bits.sh OLD_BINARY NEW_BINARY}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

strip() {
    python3 -c '
import json, sys
s = json.load(sys.stdin)
for k in ("wall_seconds", "steps_per_second", "phase_seconds", "backend_hint"):
    s.pop(k, None)
print(json.dumps(s, sort_keys=True, indent=1))
'
}

scenes=$("$old" scenes | awk '{print $1}')
status=0
for scene in $scenes; do
    for side in old new; do
        bin=$old; [ "$side" = new ] && bin=$new
        "$bin" run "$scene" --json | strip > "$work/$scene.$side.json"
    done
    if cmp -s "$work/$scene.old.json" "$work/$scene.new.json"; then
        echo "same    $scene"
    else
        echo "DIFFERS $scene"
        diff "$work/$scene.old.json" "$work/$scene.new.json" | head -20 || true
        status=1
    fi
done
for run in "two-spheres --backend sph" "two-spheres --backend lj" "two-spheres --backend mls-implicit" "pile --backend mls-implicit --steps 60" "pile --backend sph --steps 300" "plastic-fracture --backend lj --steps 600"; do
    name=${run// /_}
    for side in old new; do
        bin=$old; [ "$side" = new ] && bin=$new
        # shellcheck disable=SC2086 # the run's words are its arguments
        "$bin" run $run --json | strip > "$work/$name.$side.json"
    done
    if cmp -s "$work/$name.old.json" "$work/$name.new.json"; then
        echo "same    $run"
    else
        echo "DIFFERS $run"
        diff "$work/$name.old.json" "$work/$name.new.json" | head -20 || true
        status=1
    fi
done
for side in old new; do
    bin=$old; [ "$side" = new ] && bin=$new
    "$bin" run two-spheres --steps 150 --out "$work/frames.$side" --phyxels > /dev/null
done
if diff -r "$work/frames.old" "$work/frames.new" > /dev/null; then
    echo "same    two-spheres frames ($(ls "$work/frames.old" | wc -l) files)"
else
    echo "DIFFERS two-spheres frames"
    status=1
fi
exit $status
