#!/usr/bin/env bash
# Build knobs (environment variables read by the accel build) against each other, interleaved;
# OUT/knob.jsonl. KNOBS: ';'-separated lists of VAR=VALUE assignments ('' = defaults).
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
out=$OUT/knob.jsonl; : > $out
for n in ${TRIS:-2000000 8000000}; do python3 bench/make_big_scene.py /tmp/big$n --triangles $n > /dev/null; done
IFS=';' read -ra KS <<< "${KNOBS:-x}"
for round in $(seq ${ROUNDS:-2}); do
for n in ${TRIS:-2000000 8000000}; do for i in ${INTEGRATORS:-nee}; do for k in "${KS[@]}"; do
  [ "$k" = x ] && k=""
  env $k .carry/main/candela render /tmp/big$n/big.json -o /tmp/x.exr --integrator $i --accel ${ACCEL:-cwbvh} \
    --width 1280 --height 720 --time ${TIME:-1.5} --warmup 0.5 --json > /tmp/r.json 2>/tmp/r.err || { echo "FAIL $n $i $k: $(tail -2 /tmp/r.err)"; continue; }
  python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'round':sys.argv[1],'tris':sys.argv[2],'integrator':sys.argv[3],'knobs':sys.argv[4],'msamples_per_s':d.get('msamples_per_s'),'build_s':d.get('bvh_build_s'),'depth':d.get('bvh_depth'),'cache':str(d.get('accel_cache'))}))" $round $n $i "$k" >> $out
done; done; done; done
python3 - $out <<'PY'
import json, sys, collections, statistics as st
r = collections.defaultdict(list); b = collections.defaultdict(list)
for l in open(sys.argv[1]):
    d = json.loads(l); k = (d['tris'], d['integrator'], d['knobs']); r[k].append(d['msamples_per_s']); b[k].append(d['build_s'])
base = {k[:2]: st.median(v) for k, v in r.items() if k[2] == ''}
for k, v in sorted(r.items()):
    m = st.median(v); print(*k[:2], repr(k[2]), round(m, 1), 'x%.3f' % (m / base[k[:2]]), 'build', [round(x, 2) for x in b[k]], [round(x, 1) for x in v])
PY
