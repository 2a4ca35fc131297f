#!/usr/bin/env bash
# Peer benchmark: SPlisHSPlasH elastic solids (PyPI pysplishsplash 2.19.0), headless.
# Usage: benches/peers/splishsplash.sh [--quick] [--threads 1,2] [--cases cantilever,ball-impact] [...]
# (all arguments go to splishsplash.py; see --help). Prints one JSON object per run on stdout.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
venv=${PEERS_VENV:-$HOME/.cache/phyxel-peers/venv}

# The wheel bundles libGLU, which needs the system's libGL.so.1 (Debian: libgl1, which pulls
# in libglx0 and libglvnd0) and libX11 (libx11-6), even though we never open a window.
libdir=/usr/lib/$(uname -m)-linux-gnu
if [ ! -e "$libdir/libGL.so.1" ] || [ ! -e "$libdir/libGLdispatch.so.0" ] || [ ! -e "$libdir/libX11.so.6" ]; then
    if [ "$(id -u)" = 0 ]; then
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libgl1 libx11-6 >&2
    else
        echo "splishsplash.sh: need Debian packages libgl1 libx11-6 (apt-get install libgl1 libx11-6)" >&2
        exit 1
    fi
fi

if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/pip" show -q pysplishsplash 2>/dev/null; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install -q pysplishsplash==2.19.0 numpy >&2
fi

# The wheel also bundles its own libGLdispatch; with the system libGLX loaded beside it (via
# libGL.so.1) the import segfaults. Preloading the system libGLdispatch makes both use one copy.
export LD_PRELOAD="$libdir/libGLdispatch.so.0${LD_PRELOAD:+:$LD_PRELOAD}"
exec "$venv/bin/python" "$here/splishsplash.py" "$@"
