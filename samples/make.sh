#!/bin/sh
# Regenerates the bundled sample scans with `sharpedge synth` (tests/samples.rs runs these
# same lines and checks that the committed files are byte for byte what they make).
# Usage, from the repository root: cargo build --release && PATH=$PWD/target/release:$PATH samples/make.sh
set -eu
cd "$(dirname "$0")"
# A 100-unit box, rotated at random, 20,000 points, noise sigma 0.15 spacings, edges rounded
# with a radius of 1.5 spacings (the scan's abnormality at its edges): the pipeline's sample.
sharpedge -q synth --part box --points 20000 --noise 0.15 --round 1.5 --rotate --seed 7 --out box.ply
# An L-block with a concave edge, 15,000 points, the same scan defects.
sharpedge -q synth --part lblock --points 15000 --noise 0.15 --round 1.5 --rotate --seed 8 --out lblock.ply
