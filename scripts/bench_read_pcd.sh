#!/usr/bin/env bash
# Issue 16's PCD reading-speed requirement, measured in one run on this machine: the same
# POINTS points (float x y z + colour) as a binary PLY, a PCD `binary` and a PCD
# `binary_compressed`, read by sharpedge (`io::read`, examples/pcd_read.rs) and the two PCD
# files by PCL 1.13's pcl::io::loadPCDFile into PointXYZRGB (scripts/pcl_read_pcd.cpp), one
# process per read, alternating, median of RUNS. Prints a table of medians, the ratios the
# issue asks for and each reader's peak memory (VmHWM) beside the decoded cloud plus one
# file buffer.
#
# Usage: scripts/bench_read_pcd.sh [POINTS] [RUNS]   (defaults 10000000 3)
# The files go to /dev/shm (or $TMPDIR), never into the repository. Installs Debian's
# libpcl-dev when PCL is missing (a large download), so it is not part of the test run.
set -euo pipefail
cd "$(dirname "$0")/.."
POINTS=${1:-10000000}
RUNS=${2:-3}

# shellcheck source=scripts/pcl_build.sh
. scripts/pcl_build.sh
ref=target/pcl/pcl_read_pcd
pcl_build scripts/pcl_read_pcd.cpp "$ref" pcl_io pcl_common
cargo build --release --locked -q --example pcd_read
se=target/release/examples/pcd_read

base=/dev/shm
[ -d "$base" ] && [ -w "$base" ] || base=${TMPDIR:-/tmp}
work=$(mktemp -d "$base/sharpedge-pcd-bench.XXXXXX")
trap 'rm -rf "$work"' EXIT
"$se" gen "$work" "$POINTS"
ls -l "$work" | awk 'NR > 1 {printf "  %-16s %6.0f MB\n", $9, $5 / 1e6}'

# One column of times and one of peak RSS per reader.
readers=(ply_se binary_se compressed_se binary_pcl compressed_pcl)
for r in "${readers[@]}"; do : > "$work/$r.t"; : > "$work/$r.m"; done
measure() { # NAME COMMAND...
    local name=$1; shift
    local out
    out=$("$@")
    echo "$out" | awk '{print $1}' >> "$work/$name.t"
    echo "$out" | awk '{print $3}' >> "$work/$name.m"
}
for _ in $(seq "$RUNS"); do
    measure ply_se "$se" read "$work/cloud.ply"
    measure binary_se "$se" read "$work/binary.pcd"
    measure binary_pcl "$ref" "$work/binary.pcd"
    measure compressed_se "$se" read "$work/compressed.pcd"
    measure compressed_pcl "$ref" "$work/compressed.pcd"
done
median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
declare -A t m
for r in "${readers[@]}"; do
    t[$r]=$(median < "$work/$r.t")
    m[$r]=$(median < "$work/$r.m")
done
# The decoded cloud: f64 x y z plus three uchar colours a point (sharpedge's Cloud).
cloud_mb=$(echo "$POINTS * 27 / 1048576" | bc -l)
size_mb() { echo "$(stat -c %s "$work/$1") / 1048576" | bc -l; }
echo
echo "reading $POINTS points, median of $RUNS (one process per read, alternating):"
printf "  %-34s %8s %12s %14s\n" "reader" "seconds" "peak RSS MB" "cloud+file MB"
row() { printf "  %-34s %8.3f %12.0f %14s\n" "$1" "${t[$2]}" "${m[$2]}" "$3"; }
row "sharpedge, binary PLY" ply_se "$(printf %.0f "$(echo "$cloud_mb + $(size_mb cloud.ply)" | bc -l)")"
row "sharpedge, PCD binary" binary_se "$(printf %.0f "$(echo "$cloud_mb + $(size_mb binary.pcd)" | bc -l)")"
row "sharpedge, PCD binary_compressed" compressed_se "$(printf %.0f "$(echo "$cloud_mb + $(size_mb binary.pcd)" | bc -l)")"
row "PCL loadPCDFile, PCD binary" binary_pcl "-"
row "PCL loadPCDFile, binary_compressed" compressed_pcl "-"
ratio() { echo "$1 / $2" | bc -l | cut -c1-5; }
echo "ratios (requirement <= 1):"
echo "  PCD binary / PLY:                 $(ratio "${t[binary_se]}" "${t[ply_se]}")"
echo "  PCD binary_compressed / PLY:      $(ratio "${t[compressed_se]}" "${t[ply_se]}")"
echo "  PCD binary / PCL:                 $(ratio "${t[binary_se]}" "${t[binary_pcl]}")"
echo "  PCD binary_compressed / PCL:      $(ratio "${t[compressed_se]}" "${t[compressed_pcl]}")"
echo "(cloud+file MB: sharpedge's decoded cloud, 27 bytes a point, plus the uncompressed file)"
