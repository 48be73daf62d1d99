#!/usr/bin/env bash
set -u
export OUT
CASES="scenes/cornell.json:bdpt:auto scenes/cornell.json:deferred:auto scenes/cornell.json:nee:auto" \
BINS=".carry/new/candela .carry/filt/candela .carry/filt/candela@FILTER_WHOLE_ONLY=1 .carry/filt/candela@FILTER_LINEAR_SEARCH=1" ROUNDS=2 TIME=1 WARMUP=0.4 bash bench/results/h100-regen-1127/bins.sh
