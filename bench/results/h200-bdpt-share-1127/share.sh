#!/usr/bin/env bash
# bdpt light_share: Msamples/s and relMSE at equal time. OUT/share.jsonl, OUT/err.jsonl
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
bin=.carry/new/candela; out=$OUT
: > $out/share.jsonl; : > $out/err.jsonl
for round in 1 2; do
for s in cornell mirror_glass lights envmap shade textured_mesh; do
  for k in 1 2 4 8; do
    $bin render scenes/$s.json -o /tmp/x.exr --integrator bdpt --options "{\"light_share\":$k}" --width 1280 --height 720 \
      --time 1.5 --warmup 0.5 --json > /tmp/r.json 2>/tmp/r.err || { echo "FAIL $s $k: $(tail -2 /tmp/r.err)"; continue; }
    python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'round':$round,'scene':'$s','k':$k,'msamples_per_s':d['msamples_per_s'],'regs':(d.get('kernel_stats') or {}).get('Register Count'),'details':d.get('details')}))" >> $out/share.jsonl
  done
done
done
# References: nee 8 s (cornell, lights), bdpt light_share 1 for 15 s (mirror_glass, shade).
for c in cornell:nee:8:'{}' lights:nee:8:'{}' mirror_glass:bdpt:15:'{"light_share":1}' shade:bdpt:15:'{"light_share":1}'; do
  IFS=: read -r s i t o <<< "$c"
  $bin render scenes/$s.json -o /tmp/ref_$s.exr --integrator $i --options "$o" --width 1280 --height 720 --time $t --warmup 0.3 --seed 777 > /dev/null 2>&1 || echo "FAIL ref $s"
done
for s in cornell lights mirror_glass shade; do
  for t in 1; do for seed in 5 6; do for k in 1 2 4 8; do
    $bin render scenes/$s.json -o /tmp/e.exr --integrator bdpt --options "{\"light_share\":$k}" --width 1280 --height 720 --time $t --warmup 0.3 --seed $seed --json > /tmp/r.json 2>/dev/null || { echo "FAIL err $s $k"; continue; }
    $bin compare /tmp/e.exr /tmp/ref_$s.exr --json > /tmp/c.json
    python3 -c "import json; d=json.load(open('/tmp/r.json')); c=json.load(open('/tmp/c.json')); print(json.dumps({'scene':'$s','k':$k,'time':$t,'seed':$seed,'spp':d['spp'],'msamples_per_s':d['msamples_per_s'],'rel_mse':c['metrics']['rel_mse']}))" >> $out/err.jsonl
  done; done; done
done
python3 - $out <<'PY'
import json, sys, collections, statistics as st
out = sys.argv[1]
r = collections.defaultdict(list)
for l in open(out + '/share.jsonl'):
    d = json.loads(l); r[(d['scene'], d['k'])].append(d['msamples_per_s'])
for (s, k), v in sorted(r.items()):
    b = st.median(r[(s, 1)])
    print('rate', s, k, round(st.median(v), 1), 'x%.3f' % (st.median(v) / b), [round(x, 1) for x in v])
for l in open(out + '/err.jsonl'):
    d = json.loads(l); print('err', d['scene'], d['time'], d['seed'], d['k'], 'spp', d['spp'], 'relMSE %.4e' % d['rel_mse'])
PY
