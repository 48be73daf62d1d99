#!/usr/bin/env bash
# Session 2026-11-26c calls 6 and 7: busy at 10 ms through the server, main (609ed54) vs new (call 6: a231845, the first pass waited for at once; call 7: 553edc1, no odd half in a 1-spp snapshot), 3 rounds.
set -u
. bench/gpu_env.sh
for r in 1 2 3; do for b in main new; do
  timeout 100 python3 bench/server_latency.py --candela .carry/$b/candela --out /tmp/busy_${b}_$r --tests busy --budgets 0.01 --busy-sizes 1280x720,256x256 > /tmp/busy_${b}_$r.log 2>&1
  python3 - /tmp/busy_${b}_$r/results.jsonl $b $r <<'PY'
import json, sys
for l in open(sys.argv[1]):
    d = json.loads(l)
    if d.get('test') != 'busy': continue
    s = d['stats']; fp = s.get('first_pass') or {}
    print(sys.argv[2], sys.argv[3], d['size'], d['integrator'], 'busy %.3f' % d['busy'], 'time %.2f gpu %.2f' % (s['time_s']*1e3, s['gpu_time_s']*1e3),
          'first wall %.2f gpu %.2f' % (fp.get('wall_ms', 0), fp.get('gpu_ms', 0)), 'passes', s['passes'], 'spp', s['spp'])
PY
done; done | tee $OUT/busy6.txt
