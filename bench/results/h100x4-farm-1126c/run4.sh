#!/usr/bin/env bash
# Session 2026-11-26c call 4: deferred's busy fraction at a 10 ms budget by batch size (candela render).
set -u
. bench/gpu_env.sh
B=.carry/main/candela
for size in 256x256 1280x720; do w=${size%x*} h=${size#*x}
 for b in 0 4 8 16 32 64; do
  if [ $b = 0 ]; then o='{}'; else o="{\"samples_per_batch\": $b}"; fi
  for r in 1 2 3; do
   $B render scenes/cornell.json --integrator deferred --width $w --height $h --time 0.01 --warmup 0.3 --options "$o" --seed $r -o /tmp/d.exr --json 2>/dev/null |
   python3 -c "
import json,sys; d=json.load(sys.stdin); fp=d.get('first_pass') or {}
print('$size B=$b r$r', 'busy %.3f' % (d['gpu_time_s']/d['time_s']), 'time %.2f ms gpu %.2f ms' % (d['time_s']*1e3, d['gpu_time_s']*1e3), 'spp', d['spp'], 'passes', d['passes'], 'first wall %.2f gpu %.2f ms' % (fp.get('wall_ms',0), fp.get('gpu_ms',0)), 'Ms/s %.0f' % d['msamples_per_s'])" 2>&1
  done
 done
done | tee $OUT/deferred_batch.txt
for i in nee pt; do for r in 1 2; do $B render scenes/cornell.json --integrator $i --width 1280 --height 720 --time 0.01 --warmup 0.3 --seed $r -o /tmp/d.exr --json 2>/dev/null | python3 -c "
import json,sys; d=json.load(sys.stdin); fp=d.get('first_pass') or {}
print('$i 720p', 'busy %.3f' % (d['gpu_time_s']/d['time_s']), 'spp', d['spp'], 'passes', d['passes'], 'first wall %.2f gpu %.2f' % (fp.get('wall_ms',0), fp.get('gpu_ms',0)))"; done; done | tee -a $OUT/deferred_batch.txt
