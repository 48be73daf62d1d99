# usage: bash .carry/cmp.sh "name=bin ..." [scenes]
. bench/gpu_env.sh
OUT=$OUT/bd BINS="$1" ROUNDS=${ROUNDS:-2} SCENES="${2:-cornell mirror_glass lights envmap}" DESIGNS=${DESIGNS:-split} SPP=64 bash bench/gpu_bdpt.sh 2>&1 | tail -12
python3 - $OUT/bd/bdpt.jsonl <<'PY'
import json,sys,statistics as st,collections
g=collections.defaultdict(list)
for l in open(sys.argv[1]):
    d=json.loads(l)
    if 'failed' in d: continue
    t=d['details']['timings_ms']; g[(d['scene_name'],d['design'],d['build'])].append((t['light_passes'],t['camera_passes'],d['kernel_stats'].get('Register Count')))
for k,v in sorted(g.items()): print(*k, 'light %.1f camera %.1f regs %s'%(st.median(x[0] for x in v), st.median(x[1] for x in v), v[0][2]))
PY
