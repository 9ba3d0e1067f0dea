# Sourced by the scripts that measure against PCL (bench_vs_pcl.sh, bench_read_pcd.sh):
# `pcl_build SOURCE OUTPUT PKG...` installs Debian's libpcl-dev when PCL is missing (a large
# download, so these scripts are not part of the required test run) and builds SOURCE into
# OUTPUT against the pkg-config modules PKG... when OUTPUT is missing or older than SOURCE.
as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }
pcl_build() {
    local src=$1 out=$2
    shift 2
    if ! pkg-config --exists "$@" 2>/dev/null; then
        echo "installing PCL 1.13 (Debian package libpcl-dev)..." >&2
        as_root apt-get update -qq
        as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends libpcl-dev pkg-config >&2
    fi
    mkdir -p "$(dirname "$out")"
    if [ ! -x "$out" ] || [ "$src" -nt "$out" ]; then
        echo "building $out..." >&2
        # shellcheck disable=SC2046
        g++ -O2 -fopenmp -std=c++17 "$src" -o "$out" $(pkg-config --cflags --libs "$@")
    fi
}
