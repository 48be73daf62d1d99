#!/usr/bin/env bash
# Session 2026-11-26c call 1 (x4): farm 1/2/4 GPUs at 4096 spp, head (main) twice and 56d272d (base)
# once between; deferred/nee busy at a 10 ms budget (head).
set -u
R=$OUT/raw; mkdir -p $R
date +%T > $R/t0
. bench/gpu_env.sh
timeout 55 python3 bench/server_latency.py --candela .carry/main/candela --out $R/busy --integrators deferred,nee --tests busy --budgets 0.01 > $R/busy.log 2>&1; date +%T >> $R/t0
for c in main:4096:a base:4096:b main:4096:c; do IFS=: read b s tag <<< "$c"; mkdir -p $R/$tag
  OUT=$R/$tag BIN=.carry/$b/candela MULTI=0 SPP=$s CONFIGS="0 0,1 0,1,2,3" timeout 165 bash bench/gpu_farm.sh > $R/$tag.out 2>&1; date +%T >> $R/t0
  tail -4 $R/$tag.out > $OUT/$tag.txt; done
find $R -name '*.exr' -size +1M -delete
tail -30 $R/busy.log > $OUT/busy.txt
tar cJf $OUT/r.tar.xz -C $OUT raw && rm -rf $R
