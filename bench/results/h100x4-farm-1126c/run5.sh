#!/usr/bin/env bash
# Session 2026-11-26c call 5: GPU busy at a 10 ms budget through the server, every integrator,
# 609ed54 (main) against a231845 (new: the first pass waited for at once), twice each, interleaved.
set -u
. bench/gpu_env.sh
for r in 1 2; do for b in main new; do
  timeout 140 python3 bench/server_latency.py --candela .carry/$b/candela --out $OUT/busy_${b}_$r --tests busy --budgets 0.01 > $OUT/busy_${b}_$r.log 2>&1
  echo "== $b round $r"; grep "^| [0-9]" $OUT/busy_${b}_$r/*.md 2>/dev/null || tail -3 $OUT/busy_${b}_$r.log
done; done
