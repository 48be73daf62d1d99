#!/usr/bin/env bash
# Session 2026-11-26c call 9: the final build (f4b4036) on 1 / 2 / 4 GPUs through the farm,
# 4096 spp, one round (bench/gpu_farm.sh).
set -u
mkdir -p /tmp/f9; OUT=/tmp/f9 BIN=.carry/new/candela MULTI=0 SPP=4096 CONFIGS="0 0,1 0,1,2,3" timeout 280 bash bench/gpu_farm.sh > /tmp/f9.out 2>&1
tail -6 /tmp/f9.out | tee $OUT/farm9.txt
grep -h "merged the shards job=2\|done job=2 spp" /tmp/f9/*.log | cut -c1-250 | tee -a $OUT/farm9.txt
