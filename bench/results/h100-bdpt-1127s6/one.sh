#!/usr/bin/env bash
# bdpt one connection per camera vertex (define BDPT_ONE_CONNECTION) against all; and bvh vs cwbvh.
# OUT/rate.jsonl, OUT/err.jsonl
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
bin=.carry/one/candela; out=$OUT
: > $out/rate.jsonl; : > $out/err.jsonl
SC="cornell mirror_glass lights shade"
for round in 1 2; do
for s in $SC; do
  for v in all:bvh one:bvh all:cwbvh one:cwbvh; do
    IFS=: read -r k a <<< "$v"; d=""; [ $k = one ] && d=BDPT_ONE_CONNECTION
    CANDELA_SHADER_DEFINES="$d" $bin render scenes/$s.json -o /tmp/x.exr --integrator bdpt --accel $a --width 1280 --height 720 \
      --time 1.5 --warmup 0.5 --json > /tmp/r.json 2>/tmp/r.err || { echo "FAIL $s $v: $(tail -2 /tmp/r.err)"; continue; }
    python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'round':$round,'scene':'$s','v':'$v','msamples_per_s':d['msamples_per_s'],'rays':d['rays'],'spp':d['spp'],'regs':(d.get('kernel_stats') or {}).get('Register Count'),'details':d.get('details')}))" >> $out/rate.jsonl
  done
done
done
for c in cornell:nee:8:'{}' lights:nee:8:'{}' mirror_glass:bdpt:15:'{}' shade:bdpt:15:'{}'; do
  IFS=: read -r s i t o <<< "$c"
  $bin render scenes/$s.json -o /tmp/ref_$s.exr --integrator $i --options "$o" --width 1280 --height 720 --time $t --warmup 0.3 --seed 777 > /dev/null 2>&1 || echo "FAIL ref $s"
done
for s in $SC; do
  for seed in 5 6; do for k in all one; do
    d=""; [ $k = one ] && d=BDPT_ONE_CONNECTION
    CANDELA_SHADER_DEFINES="$d" $bin render scenes/$s.json -o /tmp/e.exr --integrator bdpt --width 1280 --height 720 --time 1 --warmup 0.3 --seed $seed --json > /tmp/r.json 2>/dev/null || { echo "FAIL err $s $k"; continue; }
    $bin compare /tmp/e.exr /tmp/ref_$s.exr --json > /tmp/c.json
    python3 -c "import json; d=json.load(open('/tmp/r.json')); c=json.load(open('/tmp/c.json')); print(json.dumps({'scene':'$s','k':'$k','seed':$seed,'spp':d['spp'],'msamples_per_s':d['msamples_per_s'],'rel_mse':c['metrics']['rel_mse']}))" >> $out/err.jsonl
  done; done
done
python3 - $out <<'PY'
import json, sys, collections, statistics as st
out = sys.argv[1]
r = collections.defaultdict(list); rays = {}
for l in open(out + '/rate.jsonl'):
    d = json.loads(l); r[(d['scene'], d['v'])].append(d['msamples_per_s']); rays[(d['scene'], d['v'])] = d['rays'] / (d['spp'] * 1280 * 720)
for (s, v), x in sorted(r.items()):
    b = st.median(r[(s, 'all:bvh')])
    print('rate', s, v, round(st.median(x), 1), 'x%.3f' % (st.median(x) / b), [round(y, 1) for y in x], 'rays/sample %.2f' % rays[(s, v)])
for l in open(out + '/err.jsonl'):
    d = json.loads(l); print('err', d['scene'], d['seed'], d['k'], 'spp', d['spp'], 'relMSE %.4e' % d['rel_mse'])
PY
