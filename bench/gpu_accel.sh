#!/usr/bin/env bash
# Issue 12 on the NVIDIA GPU machine (../shared/gpu/README.md): nee at 1280x720, max_depth 6, for
# TIME seconds (default 2) after a 1 s warm-up, cold builds (--no-accel-cache), on
# (1) the Cornell box and bench/make_big_scene.py meshes of TRIS triangles (default "2000000
#     8000000") with each --accel of ACCELS (default "bvh cwbvh") and each binary of BINS
#     (default .carry/main/candela, and .carry/base/candela when present: before/after in one
#     call): Msamples/s, build time, bytes per triangle, peak RSS;
# (2) PART instanced: bench/make_instanced_scene.py (INST_TRIS triangles placed INSTANCES times,
#     default 2000000 x 500, about 1e9 triangles) with the first binary: load, build, Msamples/s,
#     GPU bytes per instance, peak RSS.
# PARTS (default "meshes instanced"). Writes OUT/accel.jsonl; prints a table.
set -u
cd "$(dirname "$0")/.."
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
bins=${BINS:-.carry/main/candela $( [ -x .carry/base/candela ] && echo .carry/base/candela)}
parts=${PARTS:-meshes instanced}
has() { case " $parts " in *" $1 "*) return 0;; esac; return 1; }
out=${OUT:-/tmp}
jsonl="$out/accel.jsonl"
: > "$jsonl"
R="--integrator nee --max-depth 6 --width 1280 --height 720 --warmup 1 --time ${TIME:-2} --no-accel-cache --json"
row() { # binary, scene label, accel, report file
  python3 - "$@" >> "$jsonl" <<'PY'
import json, sys
d = json.load(open(sys.argv[4]))
keep = ("msamples_per_s", "triangles", "instances", "instanced_triangles", "accel_build_s",
        "load_s", "compile_s", "gpu_bytes_per_triangle", "gpu_bytes_per_instance",
        "scene_gpu_bytes", "peak_rss_bytes", "bvh_depth", "spp", "time_s", "accel_phases")
print(json.dumps({"bin": sys.argv[1], "scene": sys.argv[2], "accel": sys.argv[3],
                  **{k: d.get(k) for k in keep}}))
PY
}
if has meshes; then
  scenes="scenes/cornell.json"
  for n in ${TRIS:-2000000 8000000}; do
    python3 bench/make_big_scene.py /tmp/big$n --triangles $n > /dev/null
    scenes="$scenes /tmp/big$n/big.json"
  done
  for s in $scenes; do
    for acc in ${ACCELS:-bvh cwbvh}; do
      for bin in $bins; do
        "$bin" render "$s" -o /tmp/a.exr --accel $acc $R > /tmp/a.json && row "$bin" "$s" $acc /tmp/a.json
      done
    done
  done
fi
if has instanced; then
  python3 bench/make_instanced_scene.py /tmp/inst --triangles ${INST_TRIS:-2000000} \
    --instances ${INSTANCES:-500} > /dev/null
  set -- $bins
  "$1" render /tmp/inst/instanced.json -o /tmp/i.exr $R > /tmp/i.json && row "$1" instanced bvh /tmp/i.json
  python3 -c "import json; d=json.load(open('/tmp/i.json')); print({k: d.get(k) for k in ('scene_gpu_bytes','geometry_bytes','accel_bytes')})"
fi
python3 - "$jsonl" <<'PY'
import json, sys
print("| binary | scene | accel | triangles (instanced) | Msamples/s | build s | load s | B/tri | B/inst | peak RSS GB |")
print("|---|---|---|---|---|---|---|---|---|---|")
for l in open(sys.argv[1]):
    d = json.loads(l)
    print(f"| {d['bin']} | {d['scene']} | {d['accel']} | {d['triangles']} ({d.get('instanced_triangles')}) | "
          f"{d['msamples_per_s']:.1f} | {d['accel_build_s']:.3f} | {d['load_s']:.2f} | "
          f"{d['gpu_bytes_per_triangle']:.1f} | {d.get('gpu_bytes_per_instance') or 0:.0f} | "
          f"{(d['peak_rss_bytes'] or 0) / 1e9:.2f} |")
PY
