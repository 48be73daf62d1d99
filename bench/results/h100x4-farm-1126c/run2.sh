#!/usr/bin/env bash
# Session 2026-11-26c call 2 (x4): nee throughput by film size and aspect (bench/gpu_first100ms.sh
# throughput), then the farm 1/2/4 GPUs at 4096 spp, 3 rounds (head 609ed54).
set -u
R=$OUT/raw; mkdir -p $R
date +%T > $R/t0
timeout 110 bash bench/gpu_first100ms.sh .carry/main/candela $R/tp throughput > $R/tp.log 2>&1; date +%T >> $R/t0
cp $R/tp/render_summary.txt $OUT/tp.txt
mkdir -p $R/farm; OUT=$R/farm BIN=.carry/main/candela MULTI=0 SPP=4096 FARM_REPEATS=3 CONFIGS="0 0,1 0,1,2,3" timeout 440 bash bench/gpu_farm.sh > $R/farm.out 2>&1; date +%T >> $R/t0
grep -v "^{" $R/farm.out | tail -6 > $OUT/farm.txt; grep "^{" $R/farm.out | cut -c1-120 >> $OUT/farm.txt
find $R -name '*.exr' -size +1M -delete
tar cJf $OUT/r.tar.xz -C $OUT raw && rm -rf $R
