#!/usr/bin/env bash
# Checks E57 files sharpedge wrote with libE57Format, the reference implementation (through
# the PyPI package pye57, installed into a virtual environment of its own): every scan opens
# and all its records read. Debian's CloudCompare is built without its E57 plugin, so it
# cannot serve as the viewer check for E57.
#
# Usage: scripts/check_e57.sh FILE.e57...
set -euo pipefail
if [ "$#" -eq 0 ]; then
    sed -n '2,7p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi
venv=${SHARPEDGE_E57_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/sharpedge/e57-venv}
if ! "$venv/bin/python" -c "import pye57" >/dev/null 2>&1; then
    echo "installing pye57 (PyPI) into $venv..." >&2
    python3 -m venv "$venv"
    "$venv/bin/python" -m pip install --quiet pye57
fi
exec "$venv/bin/python" "$(dirname "$0")/check_e57.py" "$@"
