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
# (5) issue 14, mesh lights (PART meshlights, not in the default PARTS): the lights are the
#     N emissive triangles of one mesh (bench/make_mesh_lights.py, N = 10,000 and 100,000) and the
#     same scene with all that power in one triangle ("single"); nee with the power and the BVH
#     light sampler, max_depth 2, 1280x720: the time to an estimated relMSE of 0.01
#     (--until-rel-mse 0.01, capped at 60 s) with the true relMSE it reached, and a time ladder
#     (0.1, 0.3, 1, 3 s) against a 60 s (ML_REF_TIME) BVH-sampler reference, from which the time to a true
#     relMSE of 0.01 is interpolated (relMSE ∝ 1/time between the two rungs around it).
#     ML_UNTIL=0 skips the --until-rel-mse renders (the ladder only); ML_LAYOUT=panel makes the
#     N triangles tile a square of the single light's area and centre instead of scattering them (make_mesh_lights.py
#     --panel); rows carry "layout". ML_COUNTS (default "10000 100000 single") lists the scenes.
# PARTS (default "lights estimate auto big") picks the parts. Writes OUT/*.jsonl; prints tables.
# DRY=1: a quick run on any Vulkan device (lavapipe) before the GPU: no driver setup, the
# binary target/debug/candela, 32x18 pixels and seconds-long budgets; the same scenes.
set -u
cd "$(dirname "$0")/.."
dry=${DRY:-0}
if [ "$dry" = 1 ]; then
  bin=${CANDELA:-target/debug/candela}
  R="--width 32 --height 18 --no-accel-cache"
  ML_REF="--spp 256"; ML_CAP=5; ML_LADDER="0.2 0.5"; ML_WARM=0
else
  for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  bin=${CANDELA:-.carry/main/candela}
  R="--width 1280 --height 720 --no-accel-cache"
  ML_REF="--time ${ML_REF_TIME:-60}"; ML_CAP=60; ML_LADDER="0.1 0.3 1 3"; ML_WARM=1
fi
out=${OUT:-/tmp}
parts=${PARTS:-lights estimate auto big}
has() { case " $parts " in *" $1 "*) return 0;; esac; return 1; }
if [ "$dry" != 1 ]; then
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$out/gpu.txt"
fi
tag() { python3 -c "import json,sys; d=json.load(sys.stdin); d.update($1); print(json.dumps(d))"; }
true_rel() { "$bin" compare "$1" "$2" --json | python3 -c "import json,sys; print(json.load(sys.stdin)['metrics']['rel_mse'])"; }

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

if has meshlights; then
  : > "$out/meshlights.jsonl"
  for sc in ${ML_COUNTS:-10000 100000 single}; do
    scene=/tmp/mesh_lights_$sc.json
    if [ $sc = single ]; then
      python3 bench/make_mesh_lights.py 1 $scene --single
    else
      python3 bench/make_mesh_lights.py $sc $scene ${ML_LAYOUT:+--$ML_LAYOUT}
    fi
    "$bin" render $scene -o /tmp/mlm_ref.exr --integrator nee --light-sampler bvh --max-depth 2 \
      $ML_REF $R > /dev/null || exit 1
    for s in power bvh; do
      # The time to an estimated relMSE of 0.01, and the true relMSE there (ML_UNTIL=0: skip).
      if [ "${ML_UNTIL:-1}" = 1 ]; then
        "$bin" render $scene -o /tmp/mlm.exr --integrator nee --light-sampler $s --max-depth 2 \
          --warmup $ML_WARM --until-rel-mse 0.01 --time $ML_CAP $R --json > /tmp/row.json || exit 1
        rel=$(true_rel /tmp/mlm.exr /tmp/mlm_ref.exr)
        tag "{'scene_lights': '$sc', 'sampler': '$s', 'mode': 'until', 'layout': '${ML_LAYOUT:-scattered}', 'true_rel_mse': $rel}" \
          < /tmp/row.json >> "$out/meshlights.jsonl"
      fi
      # The ladder: fixed times, true relMSE against the reference.
      for t in $ML_LADDER; do
        "$bin" render $scene -o /tmp/mlm.exr --integrator nee --light-sampler $s --max-depth 2 \
          --warmup $ML_WARM --time $t $R --json > /tmp/row.json || exit 1
        rel=$(true_rel /tmp/mlm.exr /tmp/mlm_ref.exr)
        tag "{'scene_lights': '$sc', 'sampler': '$s', 'mode': 'ladder', 'layout': '${ML_LAYOUT:-scattered}', 'true_rel_mse': $rel}" \
          < /tmp/row.json >> "$out/meshlights.jsonl"
      done
    done
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
r = rows("meshlights.jsonl")
if r:
    import math
    print("| lights | sampler | until 0.01: time s | spp | stopped by | estimate | true relMSE | true 0.01 at (ladder) s |")
    print("|---|---|---|---|---|---|---|---|")
    for d in [d for d in r if d["mode"] == "until"]:
        ladder = sorted((x["time_s"], x["true_rel_mse"]) for x in r if x["mode"] == "ladder"
                        and x["scene_lights"] == d["scene_lights"] and x["sampler"] == d["sampler"])
        # relMSE ∝ 1/time: interpolate log-log between the rungs around 0.01 (else extrapolate
        # from the nearest rung).
        at = "-"
        for (t0, e0), (t1, e1) in zip(ladder, ladder[1:]):
            if e0 >= 0.01 >= e1 and e0 > e1 > 0:
                k = math.log(e0 / 0.01) / math.log(e0 / e1)
                at = f"{t0 * (t1 / t0) ** k:.3g}"
        if at == "-" and ladder:
            t, e = min(ladder, key=lambda x: abs(math.log(max(x[1], 1e-30) / 0.01)))
            at = f"~{t * e / 0.01:.3g} (1/t from {t} s)"
        print(f"| {d['scene_lights']} | {d['sampler']} | {d['time_s']:.3f} | {d['spp']} | {d.get('stopped_by')} | "
              f"{d.get('rel_mse_estimate')} | {d['true_rel_mse']:.3g} | {at} |")
for d in rows("big.jsonl"):
    keep = {k: d.get(k) for k in ("triangles", "bvh_depth", "msamples_per_s", "spp", "bvh_build_s", "accel_bytes", "geometry_bytes",
                                  "load_s", "compile_s", "scene_gpu_bytes", "gpu_bytes_per_triangle", "peak_rss_bytes")}
    print("big", json.dumps(keep)[:800])
PY
