#!/usr/bin/env bash
# Instanced scenes, two binaries (BINS) interleaved; OUT/inst.jsonl.
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
out=$OUT/inst.jsonl; : > $out
for ti in ${INSTANCED:-2000000:500 20000:50000}; do
  python3 bench/make_instanced_scene.py /tmp/inst_${ti/:/x} --triangles ${ti%%:*} --instances ${ti##*:} > /dev/null
done
for round in $(seq ${ROUNDS:-2}); do
for ti in ${INSTANCED:-2000000:500 20000:50000}; do for i in ${INTEGRATORS:-nee pt}; do for bin in ${BINS:-.carry/main/candela .carry/new/candela}; do
  "$bin" render /tmp/inst_${ti/:/x}/instanced.json -o /tmp/x.exr --integrator $i --width 1280 --height 720 \
    --time ${TIME:-1.5} --warmup 0.5 --json > /tmp/r.json 2>/tmp/r.err || { echo "FAIL $ti $i $bin: $(tail -2 /tmp/r.err)"; continue; }
  python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'round':sys.argv[1],'scene':sys.argv[2],'integrator':sys.argv[3],'bin':sys.argv[4],'msamples_per_s':d.get('msamples_per_s'),'regs':(d.get('kernel_stats') or {}).get('Register Count'),'instanced_triangles':d.get('instanced_triangles'),'build_s':d.get('bvh_build_s')}))" $round $ti $i $bin >> $out
done; done; done; done
python3 - $out <<'PY'
import json, sys, collections, statistics as st
r = collections.defaultdict(list); regs = {}
for l in open(sys.argv[1]):
    d = json.loads(l); k = (d['scene'], d['integrator'], d['bin']); r[k].append(d['msamples_per_s']); regs[k] = d['regs']
for k, v in sorted(r.items()):
    print(*k, round(st.median(v), 1), 'regs', regs[k], [round(x, 1) for x in v])
PY
