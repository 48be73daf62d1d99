#!/usr/bin/env bash
# bdpt throughput, builds side by side (issue 13): Msamples/s of `candela render --json` at
# 1280×720 max_depth 6 for each build, scene and design, in interleaved rounds, on the GPU
# machine (../shared/gpu/README.md). Kernels are compiled by a first untimed render per build,
# scene and design.
#   usage: OUT=DIR BINS="name=path ..." [ROUNDS=3] [SCENES="cornell mirror_glass lights envmap"]
#          [DESIGNS="split per_pixel"] [SPP=64] bash bench/gpu_bdpt.sh
# Writes $OUT/bdpt.jsonl (one report per render, with "build", "design", "round") and prints the
# medians per build, scene and design.
set -uo pipefail
out=${OUT:?OUT=DIR}; mkdir -p "$out"
rounds=${ROUNDS:-3}; scenes=${SCENES:-cornell mirror_glass lights envmap}
designs=${DESIGNS:-split per_pixel}; spp=${SPP:-64}
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>/dev/null
for b in ${BINS:?BINS=\"name=path ...\"}; do
  for s in $scenes; do
    for d in $designs; do
      "${b#*=}" render "scenes/$s.json" --integrator bdpt --width 64 --height 64 --spp 1 \
        --options "{\"design\": \"$d\"}" -o /tmp/w.exr > /dev/null 2>&1
    done
  done
done
for r in $(seq 1 "$rounds"); do
  for s in $scenes; do
    for d in $designs; do
      for b in $BINS; do
        name=${b%%=*}; bin=${b#*=}
        "$bin" render "scenes/$s.json" --integrator bdpt --width 1280 --height 720 --max-depth 6 \
          --spp "$spp" --options "{\"design\": \"$d\"}" -o /tmp/b.exr --json 2>> "$out/stderr.log" |
          python3 -c "import json,sys; d=json.load(sys.stdin); d.update(build='$name', design='$d', round=$r, scene_name='$s'); print(json.dumps(d))" >> "$out/bdpt.jsonl" ||
          echo "{\"failed\": \"$name $s $d $r\"}" >> "$out/bdpt.jsonl"
      done
    done
  done
done
python3 - "$out/bdpt.jsonl" <<'PY'
import json, sys, statistics as st
rows = [json.loads(l) for l in open(sys.argv[1])]
for r in rows:
    if 'failed' in r: print('FAILED', r['failed'])
ok = [r for r in rows if 'failed' not in r]
keys = sorted({(r['scene_name'], r['design']) for r in ok})
builds = list(dict.fromkeys(r['build'] for r in ok))
print('scene design ' + ' '.join(f'{b}:Msamples/s {b}:Mrays/s' for b in builds))
for k in keys:
    cells = []
    for b in builds:
        sel = [r for r in ok if (r['scene_name'], r['design']) == k and r['build'] == b]
        cells.append(f"{st.median(r['msamples_per_s'] for r in sel):.1f} {st.median(r['rays_per_s'] for r in sel)/1e6:.0f}" if sel else '- -')
    print(k[0], k[1], ' '.join(cells))
PY
