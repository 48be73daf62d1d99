#!/usr/bin/env bash
# The binary BVH's leaf collapse knobs: OUT/leaf.jsonl; medians and ratios to the default.
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
bin=.carry/leaf/candela; out=$OUT/leaf.jsonl; : > $out
for n in ${TRIS:-}; do python3 bench/make_big_scene.py /tmp/big$n --triangles $n > /dev/null; done
for round in $(seq ${ROUNDS:-1}); do
for c in $CASES; do
  IFS=: read -r s i <<< "$c"
  for v in ${VARIANTS:-4:3 4:1 1:3}; do
    IFS=: read -r leaf cost <<< "$v"
    CANDELA_BVH_LEAF=$leaf CANDELA_COLLAPSE_COST=$cost $bin render $s -o /tmp/x.exr --integrator $i --accel bvh --width 1280 --height 720 \
      --time ${TIME:-0.8} --warmup ${WARMUP:-0.3} --json > /tmp/r.json 2>/tmp/r.err || { echo "FAIL $s $i $v: $(tail -2 /tmp/r.err)"; continue; }
    python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'round':$round,'scene':'$s','integrator':'$i','v':'$v','msamples_per_s':d['msamples_per_s'],'bvh_nodes':d['bvh_nodes'],'build_s':d['accel_build_s']}))" >> $out
  done
done
done
python3 - $out <<'PY'
import json, sys, collections, statistics as st
r = collections.defaultdict(list)
for l in open(sys.argv[1]):
    d = json.loads(l); r[(d['scene'].split('/')[-1].replace('.json','') if 'big' not in d['scene'] else d['scene'].split('/')[-2], d['integrator'], d['v'])].append(d['msamples_per_s'])
for k, v in sorted(r.items()):
    b = r.get(k[:2] + ('4:3',))
    print(*k, round(st.median(v), 1), 'x%.3f' % (st.median(v) / st.median(b)) if b else '', [round(x, 1) for x in v])
PY
