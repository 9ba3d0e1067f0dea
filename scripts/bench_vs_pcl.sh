#!/usr/bin/env bash
# Issue 4's speed requirement, measured in one run on this machine: the whole sharpedge
# pipeline (`sharpedge run`, read to write, as a process) against PCL 1.13 reading the same
# file, building its k-d tree and estimating normals with curvature (NormalEstimationOMP,
# k = 16), both on the same number of threads, alternating, median of several runs.
#
# Usage: scripts/bench_vs_pcl.sh [POINTS] [RUNS] [THREADS]   (defaults 1000000 5 2)
# Installs Debian's libpcl-dev when PCL is missing (a large download), so it is not part of
# the required test run. Builds target/release/sharpedge if needed.
set -euo pipefail
cd "$(dirname "$0")/.."
POINTS=${1:-1000000}
RUNS=${2:-5}
THREADS=${3:-2}

# shellcheck source=scripts/pcl_build.sh
. scripts/pcl_build.sh
ref=target/pcl/pcl_reference
pcl_build scripts/pcl_reference.cpp "$ref" pcl_io pcl_features pcl_search pcl_kdtree pcl_common
cargo build --release --locked -q
se=target/release/sharpedge

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$se" -q synth --part box --points "$POINTS" --noise 0.15 --round 1.5 --rotate --seed 1 --out "$work/box.ply"
echo "cloud: $("$se" info "$work/box.ply" | grep -E '^(points|format)' | tr -s ' ' | paste -sd ';')"

median() { sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
: > "$work/se.txt"
: > "$work/pcl.txt"
for i in $(seq "$RUNS"); do
    s=$(date +%s.%N)
    "$se" -q run pipeline.toml --input "$work/box.ply" --out "$work/out" --threads "$THREADS"
    e=$(date +%s.%N)
    echo "$e - $s" | bc -l >> "$work/se.txt"
    OMP_NUM_THREADS=$THREADS "$ref" "$work/box.ply" 16 "$THREADS" | awk '{print $6}' >> "$work/pcl.txt"
done
se_med=$(median < "$work/se.txt")
pcl_med=$(median < "$work/pcl.txt")
echo "sharpedge run (read to write), $THREADS threads: runs $(paste -sd ' ' "$work/se.txt") s; median $se_med s"
echo "PCL read + k-d tree + NormalEstimationOMP k=16, $THREADS threads: runs $(paste -sd ' ' "$work/pcl.txt") s; median $pcl_med s"
echo "ratio sharpedge / PCL: $(echo "$se_med / $pcl_med" | bc -l | cut -c1-5) (requirement < 1)"
echo "sharpedge stage timings of the last run (report.json):"
python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); print("  " + ", ".join("%s %.2f s" % (t["stage"], t["seconds"]) for t in r["timings"]))' "$work/out/report.json"
