#!/usr/bin/env bash
# Checks LAS/LAZ runs of sharpedge with the tools GIS users have: laspy + lazrs (PyPI) read
# the rectified cloud, GDAL's ogrinfo reads edges.geojson. For autzen (LAS and LAZ),
# sample_c, lone-star (COPC) and test1_4 from ../shared/data/lidar it runs `sharpedge run`
# with the automatic output format and compares input and output point by point (see
# check_lidar.py). Installs what is missing: Debian's gdal-bin, and laspy, lazrs, numpy in a
# virtual environment under ~/.cache/sharpedge.
#
# Usage: scripts/check_lidar.sh [--self-test] [--no-install] [FILE.las|.laz ...]
#   --self-test   broken copies of a good output must fail the checks
#   --no-install  exit 3 with "skipped: laspy/ogrinfo not installed" instead of installing
# Environment: SHARPEDGE (binary; default target/release/sharpedge, built when missing),
#   SHARPEDGE_DATA (default ../shared/data), SHARPEDGE_LIDAR_VENV.
set -euo pipefail
cd "$(dirname "$0")/.."

self_test=()
install=1
files=()
for a in "$@"; do
    case "$a" in
        --self-test) self_test=(--self-test) ;;
        --no-install) install=0 ;;
        -h|--help) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) files+=("$a") ;;
    esac
done

data=${SHARPEDGE_DATA:-../shared/data}
if [ "${#files[@]}" -eq 0 ]; then
    if [ ! -d "$data/lidar" ]; then
        echo "skipped: $data/lidar absent"
        exit 0
    fi
    files=("$data/lidar/autzen_trim.las" "$data/lidar/autzen_trim.laz" "$data/lidar/sample_c.las"
           "$data/lidar/lone-star.copc.laz" "$data/lidar/test1_4.las")
    [ "${#self_test[@]}" -eq 0 ] || files=("$data/lidar/autzen_trim.las")
fi

as_root() {
    if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}
apt_updated=0
apt_install() {
    if [ "$apt_updated" -eq 0 ]; then
        as_root apt-get update -qq
        apt_updated=1
    fi
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$@" >&2
}

PYTHON=${PYTHON:-python3}
venv=${SHARPEDGE_LIDAR_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/sharpedge/lidar-venv}
have_py() { "$1" -c "import laspy, lazrs, numpy" >/dev/null 2>&1; }
if ! command -v ogrinfo >/dev/null 2>&1 || ! { have_py "$PYTHON" || have_py "$venv/bin/python"; }; then
    if [ "$install" -eq 0 ]; then
        echo "skipped: laspy/ogrinfo not installed (run scripts/check_lidar.sh to install them)"
        exit 3
    fi
fi
if ! command -v ogrinfo >/dev/null 2>&1; then
    echo "installing gdal-bin (ogrinfo)..." >&2
    apt_install gdal-bin
fi
if ! have_py "$PYTHON"; then
    # A virtual environment of its own: Debian's python3 refuses `pip install` into the
    # system (PEP 668), and the user's interpreter is left alone.
    if ! have_py "$venv/bin/python"; then
        echo "installing laspy, lazrs, numpy (PyPI) into $venv..." >&2
        if ! "$PYTHON" -m venv "$venv" >/dev/null 2>&1; then
            apt_install python3-venv
            "$PYTHON" -m venv "$venv"
        fi
        "$venv/bin/python" -m pip install --quiet laspy lazrs numpy >&2
    fi
    PYTHON=$venv/bin/python
fi

bin=${SHARPEDGE:-target/release/sharpedge}
if [ ! -x "$bin" ]; then
    cargo build --release --locked -q
fi
exec "$PYTHON" scripts/check_lidar.py "${self_test[@]}" "$bin" pipeline.toml "${files[@]}"
