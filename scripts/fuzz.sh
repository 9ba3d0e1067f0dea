#!/usr/bin/env bash
# Fuzzes the readers: scripts/fuzz.sh SECONDS [TARGET...]
#
# Builds the cargo-fuzz targets in fuzz/ (nightly toolchain and cargo-fuzz needed:
# `rustup toolchain install nightly`, `cargo install --locked cargo-fuzz`) and runs each
# target (default: all of ply las xyz mesh config pcd e57) for SECONDS, one after another on one
# core, starting from the committed seeds in fuzz/corpus-seed/<target> and the corpus kept in
# fuzz/corpus/<target> (created when missing), with the target's dictionary. A run fails on
# a crash (panic, abort), an input taking more than 1 s, more than 2048 MB of RSS or one
# allocation above 2048 MB; the input is saved in fuzz/artifacts/<target>/. The script runs
# every target and exits 1 when any failed. CI: scripts/fuzz.sh 60
# FUZZ_RUNS=N stops a target after N executions if that comes before SECONDS (the long runs:
# FUZZ_RUNS=10000000 scripts/fuzz.sh 36000 ply). TMPDIR=/dev/shm keeps the per-input files
# in memory.
#
# The targets are built as the shipped binary is (`-O`: release, no debug assertions), with
# AddressSanitizer: laz's `debug_assert!`s on decoded symbols fire on corrupt LAZ data that
# the release build reads as garbage values (an error or wrong points, never a panic).
# -detect_leaks=0: the LAS reader's decoding threads (src/io/las.rs) are still ending when
# the process exits, and LeakSanitizer then reports their thread-local destructors (112 bytes
# once, at exit, after a clean 840-s las run).
set -uo pipefail

usage="usage: scripts/fuzz.sh SECONDS [TARGET...]   (targets: ply las xyz mesh config pcd e57)"
secs=${1:-}
if ! [[ "$secs" =~ ^[0-9]+$ ]] || [ "$secs" -eq 0 ]; then
  echo "$usage" >&2
  exit 2
fi
shift
all=(ply las xyz mesh config pcd e57)
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=("${all[@]}")
for t in "${targets[@]}"; do
  if ! [[ " ${all[*]} " == *" $t "* ]]; then
    echo "fuzz.sh: unknown target '$t'; $usage" >&2
    exit 2
  fi
done

root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root/fuzz" || exit 2
# The targets write each input to a file: keep those files in a folder removed at the end.
scratch=$(mktemp -d "${TMPDIR:-/tmp}/sharpedge-fuzz.XXXXXX")
trap 'rm -rf "$scratch"' EXIT

echo "fuzz.sh: building ${targets[*]}"
for t in "${targets[@]}"; do
  cargo +nightly fuzz build -O "$t" || { echo "fuzz.sh: build of $t failed" >&2; exit 2; }
done

runs=()
if [ -n "${FUZZ_RUNS:-}" ]; then
  if ! [[ "$FUZZ_RUNS" =~ ^[0-9]+$ ]]; then
    echo "fuzz.sh: FUZZ_RUNS must be a count of executions, got '$FUZZ_RUNS'" >&2
    exit 2
  fi
  runs=(-runs="$FUZZ_RUNS")
fi

failed=()
for t in "${targets[@]}"; do
  mkdir -p "corpus/$t" "artifacts/$t"
  echo "fuzz.sh: $t for $secs s"
  # ASAN_OPTIONS too: libFuzzer's -detect_leaks=0 only stops its per-input checks, and
  # LeakSanitizer's check at exit still reported the decoding threads (CI, 2026-11-25).
  if TMPDIR="$scratch" ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0" cargo +nightly fuzz run -O "$t" "corpus/$t" "corpus-seed/$t" -- \
      -max_total_time="$secs" "${runs[@]}" -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=1 -detect_leaks=0 \
      -dict="dict/$t.dict" -print_final_stats=1 2>"$scratch/$t.log"; then
    grep -E '^stat::(number_of_executed_units|peak_rss_mb)|^Done|^INFO: -max_total_time' "$scratch/$t.log" | sed "s/^/fuzz.sh: $t: /"
  else
    failed+=("$t")
    tail -n 60 "$scratch/$t.log" >&2
    echo "fuzz.sh: $t FAILED; the input is in fuzz/artifacts/$t/" >&2
  fi
done

if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz.sh: failed: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz.sh: ${targets[*]}: no crash, timeout or memory limit in $secs s each"
