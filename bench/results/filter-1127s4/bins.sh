#!/usr/bin/env bash
# Binaries compared, interleaved: CASES "scene:integrator:accel" ...; OUT/bins.jsonl; ratio to the first of BINS.
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
out=$OUT/bins.jsonl; : > $out
for n in ${TRIS:-}; do python3 bench/make_big_scene.py /tmp/big$n --triangles $n > /dev/null; done
for round in $(seq ${ROUNDS:-2}); do
for c in $CASES; do
  IFS=: read -r s i a <<< "$c"
  for spec in $BINS; do
    bin=${spec%%@*}; defs=""; [ "$spec" != "$bin" ] && defs=${spec#*@}; defs=${defs//,/ }
    CANDELA_SHADER_DEFINES="$defs" "$bin" render "$s" -o /tmp/x.exr --integrator $i --accel $a --width ${W:-1280} --height ${H:-720} \
      --time ${TIME:-1.5} --warmup ${WARMUP:-0.5} --json > /tmp/r.json 2>/tmp/r.err || { echo "FAIL $s $i $a $bin: $(tail -2 /tmp/r.err)"; continue; }
    python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'round':sys.argv[5],'scene':sys.argv[1],'integrator':sys.argv[2],'accel':sys.argv[3],'bin':sys.argv[4],'msamples_per_s':d.get('msamples_per_s'),'rays_per_s':d.get('rays_per_s'),'regs':(d.get('kernel_stats') or {}).get('Register Count')}))" "$s" $i $a "$spec" $round >> $out
  done
done
done
python3 - $out "$BINS" <<'PY'
import json, sys, collections, statistics as st
first = sys.argv[2].split()[0]
r = collections.defaultdict(list); regs = {}
for l in open(sys.argv[1]):
    d = json.loads(l); k = (d['scene'].split('/')[-2 if 'big' in d['scene'] else -1], d['integrator'], d['accel'], d['bin'])
    r[k].append(d['msamples_per_s']); regs[k] = d['regs']
for k, v in sorted(r.items()):
    m = st.median(v); b = st.median(r[k[:3] + (first,)]) if k[:3] + (first,) in r else None
    print(*k, round(m, 1), 'x%.3f' % (m / b) if b else '', 'regs', regs[k], [round(x, 1) for x in v])
PY
