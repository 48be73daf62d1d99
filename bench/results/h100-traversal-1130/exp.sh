#!/usr/bin/env bash
# Shader variants (CANDELA_SHADER_DEFINES) of one binary, interleaved; OUT/exp.jsonl.
set -u
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
bins=${BINS:-.carry/main/candela}
out=$OUT/exp.jsonl; : > $out
for n in ${TRIS:-2000000 8000000}; do python3 bench/make_big_scene.py /tmp/big$n --triangles $n > /dev/null; done
IFS=';' read -ra VARS <<< "${VARIANTS:-;CW_MAGIC;CW_POSTPONE;CW_SHARED_STACK=8;CW_MAGIC CW_POSTPONE;CW_MAGIC CW_POSTPONE CW_SHARED_STACK=8}"
CASES=${CASES:-"scenes/cornell.json:nee scenes/textured_mesh.json:nee scenes/whitted_classic.json:whitted scenes/whitted_classic.json:nee scenes/shade.json:pt /tmp/big2000000/big.json:nee /tmp/big8000000/big.json:nee"}
for round in $(seq ${ROUNDS:-2}); do
for c in $CASES; do
  s=${c%%:*}; i=${c##*:}
  for bin in $bins; do for v in "${VARS[@]}"; do [ "$bin" != ".carry/main/candela" ] && [ -n "$v" ] && continue
    for a in ${ACCELS:-cwbvh}; do
    CANDELA_SHADER_DEFINES="$v" "$bin" render "$s" -o /tmp/x.exr --integrator $i --accel $a --width 1280 --height 720 \
      --time ${TIME:-1.5} --warmup 0.5 --json > /tmp/r.json 2>/tmp/r.err || { echo "FAIL $s $i $v: $(tail -2 /tmp/r.err)"; continue; }
    python3 -c "import json,sys; d=json.load(open('/tmp/r.json')); print(json.dumps({'round':sys.argv[5],'scene':sys.argv[1],'integrator':sys.argv[2],'accel':sys.argv[4],'variant':sys.argv[3]+('' if sys.argv[6]=='.carry/main/candela' else ' @'+sys.argv[6]),'msamples_per_s':d.get('msamples_per_s'),'regs':(d.get('kernel_stats') or {}).get('Register Count')}))" "$s" $i "$v" $a $round "$bin" >> $out
    done
  done; done
done
done
python3 - $out <<'PY'
import json, sys, collections, statistics as st
r = collections.defaultdict(list); regs = {}
for l in open(sys.argv[1]):
    d = json.loads(l); k = (d['scene'].split('/')[-2 if 'big' in d['scene'] else -1], d['integrator'], d['accel'], d['variant'])
    r[k].append(d['msamples_per_s']); regs[k] = d['regs']
base = {}
for k, v in r.items():
    if k[3] == '': base[k[:3]] = st.median(v)
for k, v in sorted(r.items()):
    m = st.median(v); b = base.get(k[:3])
    print(*k[:3], repr(k[3]), round(m, 1), 'x%.3f' % (m / b) if b else '', 'regs', regs[k], [round(x, 1) for x in v])
PY
