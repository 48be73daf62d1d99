#!/usr/bin/env bash
# vct's volume build on an NVIDIA GPU (issue 13 deliver 3: build <= 10 ms at 512^3 on the Cornell
# box): for each binary of BINS (default .carry/main/candela), each scene (Cornell, and the
# 1M-triangle bumpy sphere of bench/make_big_scene.py) and each resolution of RES (default
# "256 512 1024"), REPEATS (3) fresh processes rendering 16 spp at 1280x720; prints the GPU
# stage times of the first build (voxelize, octree, inject, filter) from `render --json`'s
# details, one JSON line per run to OUT/vct_build.jsonl, and a median table.
set -u
cd "$(dirname "$0")/.."
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
out=${OUT:-/tmp}
big=/tmp/vct_big
[ -f $big/big.json ] || python3 bench/make_big_scene.py $big --triangles 1000000 >/dev/null
: > "$out/vct_build.jsonl"
for bin in ${BINS:-.carry/main/candela}; do
  for scene in scenes/cornell.json $big/big.json; do
    for r in ${RES:-256 512 1024}; do
      for i in $(seq ${REPEATS:-3}); do
        "$bin" render "$scene" -o /tmp/vct.exr --integrator vct --spp 16 --json --no-accel-cache \
          --options "{\"resolution\": $r}" 2>/dev/null | python3 -c "
import json, sys
d = json.load(sys.stdin); t = d['details']['timings_ms']
print(json.dumps({'bin': '$bin', 'scene': '$scene', 'resolution': $r, 'voxels': d['details']['voxels'],
  'fragments': d['details']['fragments'], 'voxelize': t['voxelize'], 'octree': t['build'],
  'inject': t['inject'], 'filter': t['filter'],
  'total': t['voxelize'] + t['build'] + t['inject'] + t['filter'], 'trace_per_frame': t['trace'] / 16}))" >> "$out/vct_build.jsonl"
      done
    done
  done
done
python3 - "$out/vct_build.jsonl" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
keys = sorted({(r['bin'], r['scene'], r['resolution']) for r in rows}, key=lambda k: (k[1], k[2], k[0]))
print('| binary | scene | R | voxels | voxelize | octree | inject | filter | build ms | trace ms/frame |')
print('|---|---|---|---|---|---|---|---|---|---|')
for k in keys:
    rs = [r for r in rows if (r['bin'], r['scene'], r['resolution']) == k]
    m = lambda f: statistics.median(r[f] for r in rs)
    print(f"| {k[0]} | {k[1]} | {k[2]} | {rs[0]['voxels']} | {m('voxelize'):.2f} | {m('octree'):.2f} | "
          f"{m('inject'):.2f} | {m('filter'):.2f} | {m('total'):.2f} | {m('trace_per_frame'):.2f} |")
PY
