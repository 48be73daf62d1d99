#!/usr/bin/env bash
# On the NVIDIA GPU machine (../shared/gpu/README.md), with .carry/main/candela:
# (1) issue 14, many lights: 256 lights (bench/make_many_lights.py, max_depth 2, 1280x720), nee
#     with the power and the BVH light sampler at 10 ms, 100 ms and 1 s, true relMSE against a
#     30 s BVH-sampler render of the same scene, and the estimate each render reports;
# (2) issue 14, the error estimate: Cornell 1280x720 max_depth 6, pt / nee / bdpt at 0.1 s and 1 s,
#     estimate against the true relMSE (reference: 60 s of nee);
# (3) issue 14, auto: the integrator `--integrator auto` picks on Cornell and on mirror_glass;
# (4) issue 12: bench/make_big_scene.py meshes of 2M and 8M triangles (8M was refused before:
#     BVH depth), nee 1280x720 max_depth 6, 3 s after a 1 s warm-up, with the memory figures.
# PARTS (default "lights estimate auto big") picks the parts. Writes OUT/*.jsonl; prints tables.
set -u
cd "$(dirname "$0")/.."
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
bin=${CANDELA:-.carry/main/candela}
out=${OUT:-/tmp}
parts=${PARTS:-lights estimate auto big}
has() { case " $parts " in *" $1 "*) return 0;; esac; return 1; }
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$out/gpu.txt"
tag() { python3 -c "import json,sys; d=json.load(sys.stdin); d.update($1); print(json.dumps(d))"; }
true_rel() { "$bin" compare "$1" "$2" --json | python3 -c "import json,sys; print(json.load(sys.stdin)['metrics']['rel_mse'])"; }
R="--width 1280 --height 720 --no-accel-cache"

if has lights; then
  python3 bench/make_many_lights.py 256 /tmp/ml.json --width 1280 --height 720 > /dev/null
  "$bin" render /tmp/ml.json -o /tmp/ml_ref.exr --integrator nee --light-sampler bvh --max-depth 2 \
    --time 30 $R > /dev/null
  : > "$out/lights.jsonl"
  for t in 0.01 0.1 1; do
    for s in power bvh; do
      "$bin" render /tmp/ml.json -o /tmp/ml.exr --integrator nee --light-sampler $s --max-depth 2 \
        --warmup 1 --time $t $R --json | tag "{'sampler': '$s', 'true_rel_mse': $(echo 0)}" > /tmp/row.json
      rel=$(true_rel /tmp/ml.exr /tmp/ml_ref.exr)
      python3 -c "import json; d=json.load(open('/tmp/row.json')); d['true_rel_mse']=$rel; print(json.dumps(d))" >> "$out/lights.jsonl"
    done
  done
fi

if has estimate; then
  "$bin" render scenes/cornell.json -o /tmp/c_ref.exr --integrator nee --max-depth 6 --time 60 $R > /dev/null
  : > "$out/estimate.jsonl"
  for t in 0.1 1; do
    for i in pt nee bdpt; do
      "$bin" render scenes/cornell.json -o /tmp/c.exr --integrator $i --max-depth 6 --warmup 1 \
        --time $t $R --json > /tmp/row.json
      rel=$(true_rel /tmp/c.exr /tmp/c_ref.exr)
      python3 -c "import json; d=json.load(open('/tmp/row.json')); d['true_rel_mse']=$rel; print(json.dumps(d))" >> "$out/estimate.jsonl"
    done
  done
fi

if has auto; then
  : > "$out/auto.jsonl"
  for sc in cornell mirror_glass; do
    "$bin" render scenes/$sc.json -o /tmp/a.exr --integrator auto --time 2 $R --json \
      | tag "{'scene_file': '$sc'}" >> "$out/auto.jsonl"
  done
fi

if has big; then
  : > "$out/big.jsonl"
  for n in 2000000 8000000; do
    python3 bench/make_big_scene.py /tmp/big$n --triangles $n > /dev/null
    /usr/bin/time -v "$bin" render /tmp/big$n/big.json -o /tmp/b.exr --integrator nee --max-depth 6 \
      --warmup 1 --time 3 $R --json 2> /tmp/time.txt | tag "{'triangles_asked': $n}" >> "$out/big.jsonl"
    grep -E "Maximum resident|Elapsed" /tmp/time.txt
  done
fi

python3 - "$out" <<'PY'
import json, os, sys
out = sys.argv[1]
def rows(name):
    p = os.path.join(out, name)
    return [json.loads(l) for l in open(p)] if os.path.exists(p) else []
r = rows("lights.jsonl")
if r:
    print("| time s | sampler | spp | true relMSE | estimate |")
    print("|---|---|---|---|---|")
    for d in r:
        print(f"| {d['time_s']:.3f} | {d['sampler']} | {d['spp']} | {d['true_rel_mse']:.3g} | {d.get('rel_mse_estimate')} |")
r = rows("estimate.jsonl")
if r:
    print("| integrator | time s | spp | true relMSE | estimate | ratio |")
    print("|---|---|---|---|---|---|")
    for d in r:
        e = d.get("rel_mse_estimate")
        ratio = f"{e / d['true_rel_mse']:.2f}" if e else "-"
        print(f"| {d['integrator']} | {d['time_s']:.3f} | {d['spp']} | {d['true_rel_mse']:.3g} | {e} | {ratio} |")
for d in rows("auto.jsonl"):
    print("auto", d.get("scene_file"), "->", d.get("integrator"), json.dumps(d.get("auto"))[:600])
for d in rows("big.jsonl"):
    keep = {k: d.get(k) for k in ("triangles", "bvh_depth", "msamples_per_s", "spp", "bvh_build_s", "accel_bytes", "geometry_bytes",
                                  "load_s", "compile_s", "scene_gpu_bytes", "gpu_bytes_per_triangle", "peak_rss_bytes")}
    print("big", json.dumps(keep)[:800])
PY
