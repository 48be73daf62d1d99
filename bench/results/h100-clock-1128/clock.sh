#!/usr/bin/env bash
# Where a path kernel's thread-cycles go (COUNT_CLOCK, common/bindings.glsl): per case, the
# rate (a timed run) and, at a fixed spp, the subgroup-clock cycles summed over threads spent in
# closest-hit walks (1), any-hit walks (2) and the whole kernel (3). OUT/clock.jsonl.
# usage (repository root, device): BIN=... CASES="scene:integrator:accel ..." bash clock.sh
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version,clocks.sm,clocks.max.sm --format=csv,noheader
out=$OUT/clock.jsonl; : > $out
for n in ${TRIS:-}; do python3 bench/make_big_scene.py /tmp/big$n --triangles $n > /dev/null; done
W=${W:-1280}; H=${H:-720}; SPP=${SPP:-16}
for c in $CASES; do
  IFS=: read -r s i a <<< "$c"
  for d in base COUNT_CLOCK=1 COUNT_CLOCK=2 COUNT_CLOCK=3; do
    if [ $d = base ]; then args="--time ${TIME:-1} --warmup 0.4"; defs=""; else args="--spp $SPP --warmup 0.3"; defs=$d; fi
    CANDELA_SHADER_DEFINES="$defs" $BIN render "$s" -o /tmp/x.exr --integrator $i --accel $a --width $W --height $H $args --json > /tmp/r.json 2>/tmp/r.err || { echo "FAIL $c $d: $(tail -2 /tmp/r.err)"; continue; }
    python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'case':sys.argv[1],'defs':sys.argv[2],'msamples_per_s':d.get('msamples_per_s'),'rays':d.get('rays'),'spp':d.get('spp'),'gpu_time_s':d.get('gpu_time_s'),'time_s':d.get('time_s'),'pixels':$W*$H,'regs':(d.get('kernel_stats') or {}).get('Register Count')}))" "$c" $d >> $out
  done
done
python3 - $out <<'PY'
import json, sys, collections
rows = collections.defaultdict(dict)
for l in open(sys.argv[1]):
    d = json.loads(l); rows[d['case']][d['defs']] = d
for c, r in rows.items():
    if not all(k in r for k in ('base', 'COUNT_CLOCK=1', 'COUNT_CLOCK=2', 'COUNT_CLOCK=3')): print(c, 'incomplete'); continue
    per = {k: r[k]['rays'] / (r[k]['pixels'] * r[k]['spp']) for k in ('COUNT_CLOCK=1', 'COUNT_CLOCK=2', 'COUNT_CLOCK=3')}
    tot = per['COUNT_CLOCK=3']
    print(c, 'Msamples/s %.1f' % r['base']['msamples_per_s'], 'regs', r['base']['regs'],
          'thread-cycles/sample: total %.0f closest %.0f (%.1f%%) any %.0f (%.1f%%) rest %.1f%%' % (
          tot, per['COUNT_CLOCK=1'], 100 * per['COUNT_CLOCK=1'] / tot, per['COUNT_CLOCK=2'], 100 * per['COUNT_CLOCK=2'] / tot,
          100 * (1 - (per['COUNT_CLOCK=1'] + per['COUNT_CLOCK=2']) / tot)),
          'clocked run: %.4f s gpu, %.1f Msamples/s' % (r['COUNT_CLOCK=3']['gpu_time_s'], r['COUNT_CLOCK=3']['msamples_per_s']))
PY
