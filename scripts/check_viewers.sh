#!/usr/bin/env bash
# Checks with the real programs that PLY files written by sharpedge open in CloudCompare and
# MeshLab with their fields visible: same point count, every `scalar_*` property as a
# CloudCompare scalar field, `quality` and `red/green/blue` in MeshLab, edges of
# `element edge` in MeshLab. Installs what is missing: Debian's `cloudcompare` package (run
# headless with QT_QPA_PLATFORM=offscreen) and `pymeshlab` from PyPI.
#
# Usage: scripts/check_viewers.sh FILE.ply...
#        scripts/check_viewers.sh --self-test   (broken files must be caught)
# Sample files as the pipeline writes them:
#   SHARPEDGE_VIEWER_SAMPLES=/tmp/viewer cargo test --release --test io_viewer_samples
#   scripts/check_viewers.sh /tmp/viewer/*.ply
#
# Not part of the required test run (it installs system packages and needs a few minutes).
set -euo pipefail

if [ "$#" -eq 0 ]; then
    sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi

PYTHON=${PYTHON:-python3}

as_root() {
    if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

if ! command -v CloudCompare >/dev/null 2>&1; then
    echo "installing CloudCompare (Debian package cloudcompare)..." >&2
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends cloudcompare >&2
fi
if ! "$PYTHON" -c "import pymeshlab, numpy" >/dev/null 2>&1; then
    # In a virtual environment of its own: Debian's python3 refuses `pip install` into the
    # system (PEP 668), and the user's interpreter is left alone.
    venv=${SHARPEDGE_VIEWER_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/sharpedge/viewer-venv}
    if ! "$venv/bin/python" -c "import pymeshlab, numpy" >/dev/null 2>&1; then
        echo "installing pymeshlab (PyPI) into $venv..." >&2
        if ! "$PYTHON" -m venv "$venv" >/dev/null 2>&1; then
            as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >&2
            "$PYTHON" -m venv "$venv"
        fi
        "$venv/bin/python" -m pip install --quiet pymeshlab numpy >&2
    fi
    PYTHON=$venv/bin/python
fi

export QT_QPA_PLATFORM=offscreen
exec "$PYTHON" "$(dirname "$0")/check_viewers.py" "$@"
