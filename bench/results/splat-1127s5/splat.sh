#!/usr/bin/env bash
# Call 1 (and 2 with the FILTER_AXIS_LOOP define, since removed): HEAD (9e3f4a1) against the per-row splat weights, and the FILTER_AXIS_LOOP variant.
set -u
export OUT
CASES="scenes/cornell.json:bdpt:auto scenes/cornell.json:deferred:auto scenes/cornell.json:nee:auto" \
BINS=".carry/filt/candela .carry/row/candela .carry/row/candela@FILTER_AXIS_LOOP=1" ROUNDS=3 TIME=1 WARMUP=0.4 \
W=1280 H=720 bash bench/results/h100-regen-1127/bins.sh
