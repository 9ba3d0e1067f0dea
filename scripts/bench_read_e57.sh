#!/usr/bin/env bash
# Reading speed and memory of E57 against a binary PLY of the same points:
#   scripts/bench_read_e57.sh [POINTS] [DIR]     (defaults: 10000000, /dev/shm/sharpedge-bench-e57)
#
# Writes the same POINTS points (double x y z, ushort intensity, uchar rgb) as one-scan E57
# and as binary little-endian PLY into DIR (kept for the next run; never in the repository),
# then reads each with `sharpedge::io::read` in a fresh process, alternating PLY and E57, 3
# times each, and prints the medians: seconds, peak RSS (VmHWM), the decoded cloud's size
# and the file's size, and the E57/PLY time ratio. The requirement: E57 no slower than PLY,
# peak RSS no more than the decoded cloud plus one file buffer.
set -euo pipefail
n=${1:-10000000}
dir=${2:-/dev/shm/sharpedge-bench-e57}
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
cargo build --release --quiet --example e57_read_bench
bin=target/release/examples/e57_read_bench
mkdir -p "$dir"
if [ ! -f "$dir/points.e57" ] || [ ! -f "$dir/points.ply" ] || [ "$(cat "$dir/n" 2>/dev/null)" != "$n" ]; then
    echo "writing $n points to $dir ..." >&2
    "$bin" gen "$dir" "$n"
    echo "$n" > "$dir/n"
fi
declare -A lines
for round in 1 2 3; do
    for fmt in ply e57; do
        lines[$fmt]+="$("$bin" read "$dir/points.$fmt")"$'\n'
    done
done
median() { sort -g | sed -n 2p; }
printf '%-5s %10s %12s %14s %14s %12s\n' format points seconds "peak RSS MB" "decoded MB" "file MB"
for fmt in ply e57; do
    data=${lines[$fmt]}
    secs=$(echo -n "$data" | awk '{print $1}' | median)
    pts=$(echo -n "$data" | awk 'NR==1{print $2}')
    rss=$(echo -n "$data" | awk '{print $3/1024}' | median)
    dec=$(echo -n "$data" | awk 'NR==1{print $4/1048576}')
    file=$(echo -n "$data" | awk 'NR==1{print $5/1048576}')
    printf '%-5s %10s %12s %14.1f %14.1f %12.1f\n' "$fmt" "$pts" "$secs" "$rss" "$dec" "$file"
    eval "secs_$fmt=$secs"
done
echo "ratio E57/PLY (median seconds): $(awk -v a="$secs_e57" -v b="$secs_ply" 'BEGIN{printf "%.2f", a/b}')"
