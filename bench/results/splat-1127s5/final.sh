#!/usr/bin/env bash
# Before the exact filter (a755730's kernels), HEAD 9e3f4a1 and this commit, interleaved, one call.
set -u
export OUT
CASES="scenes/cornell.json:bdpt:auto scenes/cornell.json:deferred:auto scenes/cornell.json:nee:auto scenes/cornell.json:pt:auto scenes/cornell.json:whitted:auto scenes/cornell.json:vct:auto" \
BINS=".carry/new/candela .carry/filt/candela .carry/final/candela" ROUNDS=3 TIME=1 WARMUP=0.4 \
W=1280 H=720 bash bench/results/h100-regen-1127/bins.sh
