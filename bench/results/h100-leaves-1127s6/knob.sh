#!/usr/bin/env bash
# Build knobs (environment variables) compared on one binary: CASES "scene:integrator:accel" ...,
# VARIANTS "NAME=VALUE,..." (a lone "-" is the default). OUT/knob.jsonl; ratios to the first variant.
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
bin=${BIN:-.carry/leaf/candela}; out=$OUT/knob.jsonl; : > $out
for n in ${TRIS:-}; do python3 bench/make_big_scene.py /tmp/big$n --triangles $n > /dev/null; done
for round in $(seq ${ROUNDS:-1}); do
for c in $CASES; do
  IFS=: read -r s i a <<< "$c"
  for v in $VARIANTS; do
    env ${v//,/ } $bin render $s -o /tmp/x.exr --integrator $i --accel $a --width 1280 --height 720 \
      --time ${TIME:-0.8} --warmup ${WARMUP:-0.3} --json > /tmp/r.json 2>/tmp/r.err || { echo "FAIL $s $i $v: $(tail -2 /tmp/r.err)"; continue; }
    python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'round':$round,'scene':'$s','integrator':'$i','accel':'$a','v':'$v','msamples_per_s':d['msamples_per_s'],'bvh_nodes':d['bvh_nodes'],'build_s':d['accel_build_s']}))" >> $out
  done
done
done
python3 - $out "$VARIANTS" <<'PY'
import json, sys, collections, statistics as st
first = sys.argv[2].split()[0]
r = collections.defaultdict(list); nodes = {}
for l in open(sys.argv[1]):
    d = json.loads(l); sc = d['scene'].split('/')[-2] if 'big' in d['scene'] else d['scene'].split('/')[-1].replace('.json', '')
    k = (sc, d['integrator'], d['accel'], d['v']); r[k].append(d['msamples_per_s']); nodes[k] = (d['bvh_nodes'], round(d['build_s'], 2))
for k, v in sorted(r.items()):
    b = r.get(k[:3] + (first,))
    print(*k, round(st.median(v), 1), 'x%.3f' % (st.median(v) / st.median(b)) if b else '', [round(x, 1) for x in v], 'nodes/build', nodes[k])
PY
