#!/usr/bin/env bash
# Session 2026-11-26c call 8: HEAD (f4b4036) on a real GPU: busy at 10 ms through the server (every
# integrator, both sizes), and a split job on one GPU through the farm (the merge from memory).
set -u
. bench/gpu_env.sh
timeout 100 python3 bench/server_latency.py --candela .carry/new/candela --out /tmp/busy --tests busy --budgets 0.01 > /tmp/busy.log 2>&1
grep "^| [0-9]" /tmp/busy/summary.md | tee $OUT/busy8.txt
mkdir -p /tmp/farm; OUT=/tmp/farm BIN=.carry/new/candela MULTI=0 SPP=1024 CONFIGS="0" timeout 150 bash bench/gpu_farm.sh > /tmp/farm.out 2>&1
tail -4 /tmp/farm.out | tee $OUT/farm8.txt
grep -h "merged the shards job=2\|done job=2 spp" /tmp/farm/*.log | cut -c1-250 | tee -a $OUT/farm8.txt
