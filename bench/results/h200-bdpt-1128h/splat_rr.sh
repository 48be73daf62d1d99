#!/usr/bin/env bash
# bdpt's splat roulette (SPLAT_RR_WEIGHT, shaders/bdpt/splat.glsl) on the Cornell box (Gaussian
# filter), 1280x720 md6: Msamples/s per weight ($WEIGHTS, ROUNDS interleaved) into
# $OUT/rate.jsonl, and relMSE of 1 s renders (seeds $SEEDS) against nee for 8 s (seed 777) into
# $OUT/err.jsonl. BIN: the candela binary.
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
bin=${BIN:-.carry/e3/candela}; out=$OUT; scene=scenes/cornell.json
: > $out/rate.jsonl; : > $out/err.jsonl
for round in $(seq ${ROUNDS:-2}); do
  for w in $WEIGHTS; do
    CANDELA_SHADER_DEFINES="SPLAT_RR_WEIGHT=$w" $bin render $scene -o /tmp/x.exr --integrator bdpt --width 1280 --height 720 \
      --time ${TIME:-0.6} --warmup 0.3 --json > /tmp/r.json 2>/tmp/r.err || { echo "FAIL $w: $(tail -2 /tmp/r.err)"; continue; }
    python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'round':$round,'w':'$w','msamples_per_s':d['msamples_per_s']}))" >> $out/rate.jsonl
  done
done
$bin render $scene -o /tmp/ref.exr --integrator nee --width 1280 --height 720 --time 8 --warmup 0.3 --seed 777 > /dev/null 2>&1 || echo "FAIL ref"
for seed in $SEEDS; do for w in $EWEIGHTS; do
  CANDELA_SHADER_DEFINES="SPLAT_RR_WEIGHT=$w" $bin render $scene -o /tmp/e.exr --integrator bdpt --width 1280 --height 720 --time 1 --warmup 0.3 --seed $seed --json > /tmp/r.json 2>/dev/null || { echo "FAIL err $w"; continue; }
  $bin compare /tmp/e.exr /tmp/ref.exr --json > /tmp/c.json
  python3 -c "import json; d=json.load(open('/tmp/r.json')); c=json.load(open('/tmp/c.json')); print(json.dumps({'w':'$w','seed':$seed,'spp':d['spp'],'msamples_per_s':d['msamples_per_s'],'rel_mse':c['metrics']['rel_mse']}))" >> $out/err.jsonl
done; done
python3 - $out <<'PY'
import json, sys, collections, statistics as st
out = sys.argv[1]
r = collections.defaultdict(list)
for l in open(out + '/rate.jsonl'):
    d = json.loads(l); r[d['w']].append(d['msamples_per_s'])
for w, v in r.items(): print('rate', w, round(st.median(v), 1), [round(x, 1) for x in v])
e = collections.defaultdict(list)
for l in open(out + '/err.jsonl'):
    d = json.loads(l); e[d['w']].append(d['rel_mse']); print('err', d['w'], d['seed'], d['spp'], '%.4e' % d['rel_mse'])
for w, v in e.items(): print('relMSE mean', w, '%.4e' % st.mean(v), 'geomean', '%.4e' % st.geometric_mean(v))
PY
