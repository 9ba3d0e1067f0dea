#!/usr/bin/env bash
# Regenerates the seed corpora in fuzz/corpus-seed/<target>/ from the repository's samples
# and small generated files (fuzz/examples/make_corpus.rs; every file < 64 KB, committed).
# Run from anywhere: fuzz/make_corpus.sh
set -euo pipefail
fuzz_dir=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$fuzz_dir")
cd "$fuzz_dir"
# The library's compiled dependencies in target/ are reused.
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$root/target}"
cargo run --quiet --release --locked --example make_corpus -- "$root" "$fuzz_dir/corpus-seed"
find "$fuzz_dir/corpus-seed" -type f -size +64k -print -exec false {} + ||
  { echo "make_corpus.sh: a seed above 64 KB (listed above)" >&2; exit 1; }
echo "seeds: $(find "$fuzz_dir/corpus-seed" -type f | wc -l) files in $fuzz_dir/corpus-seed"
