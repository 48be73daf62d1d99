#!/usr/bin/env bash
# Filter change: base (.carry/new, a755730 kernels = 6091ce2's) vs .carry/filt (Mitsuba-exact Gaussian).
set -u
export OUT
CASES="scenes/cornell.json:pt:auto scenes/cornell.json:nee:auto scenes/cornell.json:bdpt:auto scenes/cornell.json:whitted:auto scenes/cornell.json:deferred:auto scenes/cornell.json:vct:auto scenes/mirror_glass.json:nee:auto scenes/mirror_glass.json:pt:auto" \
BINS=".carry/new/candela .carry/filt/candela" ROUNDS=3 TIME=1 WARMUP=0.4 bash bench/results/h100-regen-1127/bins.sh
