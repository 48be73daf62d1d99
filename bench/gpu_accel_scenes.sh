#!/usr/bin/env bash
# Issue 12 on the NVIDIA GPU machine (../shared/gpu/README.md): every integrator on every project
# scene with --accel bvh and cwbvh (1280x720, the scene's max_depth, TIME seconds (default 1)
# after a 0.5 s warm-up). Usage: bash bench/gpu_accel_scenes.sh OUT.jsonl (BIN: the binary,
# default .carry/main/candela). Writes one JSON line per run to OUT.jsonl; prints cwbvh / bvh.
set -u
cd "$(dirname "$0")/.."
. bench/gpu_env.sh
out=$1; bin=${BIN:-.carry/main/candela}
: > "$out"
tmp=$(mktemp -d)
for s in scenes/*.json; do
  for i in pt nee bdpt whitted deferred vct; do
    for a in bvh cwbvh; do
      "$bin" render "$s" -o $tmp/x.exr --integrator $i --accel $a --width 1280 --height 720 \
        --time ${TIME:-1} --warmup 0.5 --json > $tmp/r.json 2>$tmp/r.err || { echo "FAIL $s $i $a: $(tail -2 $tmp/r.err)"; continue; }
      python3 -c "import json,sys; d=json.load(open('$tmp/r.json')); print(json.dumps({'scene':sys.argv[1],'integrator':sys.argv[2],'accel':sys.argv[3],'msamples_per_s':d.get('msamples_per_s'),'compile_s':d.get('compile_s')}))" "$s" $i $a "$tmp/r.json" >> "$out"
    done
  done
done
python3 - "$out" <<'PY'
import json, sys, collections
r = collections.defaultdict(dict)
for l in open(sys.argv[1]):
    d = json.loads(l); r[(d['scene'], d['integrator'])][d['accel']] = d['msamples_per_s']
for k, v in r.items():
    if 'bvh' in v and 'cwbvh' in v:
        print(k[0][7:], k[1], round(v['bvh'], 1), round(v['cwbvh'], 1), round(v['cwbvh'] / v['bvh'], 3))
PY
