#!/usr/bin/env bash
# On the NVIDIA GPU machine (../shared/gpu/README.md), with .carry/main/candela and Mitsuba 3
# (.carry/mitsuba-cp312.tar.xz from ../shared/gpu/mitsuba-pack.sh):
# (1) issue 12, side by side (bench/vs_mitsuba.py): candela nee and Mitsuba 3 cuda `path` on the
#     same scene, film 1280x720, box filter, max_depth 6, SPP (default 256) spp: the Cornell box and
#     bench/make_big_scene.py meshes of TRIS (default 2M 8M 30M) triangles; ACCELS (default "bvh")
#     lists candela's --accel values to run; then each instanced scene of INSTANCED (default
#     "2000000:500", TRIANGLES:INSTANCES, bench/make_instanced_scene.py: ~1e9 triangles) with the
#     bvh (the one structure with a second level) at INSTANCED_SPP (default 64) spp (an empty
#     TRIS or INSTANCED runs none);
# (2) issue 14 item 6, time to relMSE 0.01 (`candela bench`, budgets TIMES (0.01 to 1 s), one run each)
#     for every integrator on every project scene (SCENES) with its film SCALE (3) times larger,
#     against a Mitsuba 3 cuda reference of REF_SPP (default 4096) spp when `candela convert` can
#     translate the scene, else candela's own nee reference.
# PARTS (default "mitsuba ttq") picks the parts. Writes OUT/vs_mitsuba.jsonl, OUT/ttq/SCENE/ and
# OUT/ttq.md; prints the tables.
set -u
cd "$(dirname "$0")/.."
. bench/gpu_env.sh
mkdir -p /tmp/mi && tar xJf .carry/mitsuba-cp312.tar.xz -C /tmp/mi && export PYTHONPATH=/tmp/mi
bin=${CANDELA:-.carry/main/candela}
out=${OUT:-/tmp}
parts=${PARTS:-mitsuba ttq}
has() { case " $parts " in *" $1 "*) return 0;; esac; return 1; }
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$out/gpu.txt"

if has mitsuba; then
  : > "$out/vs_mitsuba.jsonl"
  scenes="scenes/cornell.json"
  for n in ${TRIS-2000000 8000000 30000000}; do
    python3 bench/make_big_scene.py /tmp/big$n --triangles $n > /dev/null
    scenes="$scenes /tmp/big$n/big.json"
  done
  for s in $scenes; do
    for acc in ${ACCELS:-bvh}; do
      python3 bench/vs_mitsuba.py "$s" --candela "$bin" --spp ${SPP:-256} --candela-args "--accel $acc --no-accel-cache" \
        >> "$out/vs_mitsuba.jsonl" || echo "vs_mitsuba failed on $s ($acc)"
    done
  done
  for ti in ${INSTANCED-2000000:500}; do
    d=/tmp/inst_${ti/:/x}
    python3 bench/make_instanced_scene.py $d --triangles ${ti%%:*} --instances ${ti##*:} > /dev/null
    python3 bench/vs_mitsuba.py $d/instanced.json --candela "$bin" --spp ${INSTANCED_SPP:-64} \
      --candela-args "--accel bvh --no-accel-cache" >> "$out/vs_mitsuba.jsonl" || echo "vs_mitsuba failed on $d"
  done
  python3 - "$out/vs_mitsuba.jsonl" <<'PY'
import json, sys
print("| scene | triangles | instanced triangles | accel | spp | candela Msamples/s | Mitsuba 3 Msamples/s | ratio | images relMSE |")
print("|---|---|---|---|---|---|---|---|---|")
for l in open(sys.argv[1]):
    d = json.loads(l); c = d["candela"]
    print(f"| {d['scene']} | {c.get('triangles')} | {c.get('instanced_triangles', '')} | {c.get('accel')} | {d['spp']} | {c['msamples_per_s']:.1f} | "
          f"{d['mitsuba']['msamples_per_s']:.1f} | {d['ratio_candela_over_mitsuba']:.2f} | {d['images_rel_mse']:.3g} |")
PY
fi

if has ttq; then
  mkdir -p "$out/ttq"
  for s in ${SCENES:-cornell envmap furnace lights mirror_glass shade textured_mesh thinlens whitted_classic}; do
    d="$out/ttq/$s"; mkdir -p "$d"
    # The scene with its film SCALE times larger (default 3: 768x768 for the 256x256 scenes), beside
    # the original so that relative asset paths resolve.
    python3 -c "import json,sys; d=json.load(open('scenes/$s.json')); f=d['film']; f['width']*=${SCALE:-3}; f['height']*=${SCALE:-3}; json.dump(d, open('scenes/.ttq_$s.json','w'))"
    ref=""
    # Mitsuba's reference: REF_SPP spp in renders of 256 spp with distinct seeds, averaged.
    if "$bin" convert scenes/.ttq_$s.json scenes/.ttq_$s.xml > /dev/null 2> "$d/ref_stderr.txt" && python3 - scenes/.ttq_$s.xml "$d/mitsuba_ref.exr" "${REF_SPP:-4096}" 2> "$d/ref_stderr.txt" <<'PY'
import sys, mitsuba as mi
mi.set_variant("cuda_ad_rgb")
scene = mi.load_file(sys.argv[1])
n = max(1, int(sys.argv[3]) // 256)
acc = None
for seed in range(n):
    img = mi.render(scene, spp=256, seed=seed)
    acc = img if acc is None else acc + img
mi.Bitmap(acc / n).write(sys.argv[2])
PY
    then ref="--reference $d/mitsuba_ref.exr"
    else echo "$s: no Mitsuba reference (below); candela's nee reference"; tail -3 "$d/ref_stderr.txt"; fi
    "$bin" bench scenes/.ttq_$s.json $ref --integrators ${INTEGRATORS:-pt,nee,bdpt,vct,whitted,deferred} \
      --times ${TIMES:-0.01,0.03,0.1,0.3,1} --repeats 1 --out "$d" > /dev/null 2> "$d/stderr.txt" \
      || { echo "bench failed on $s"; tail -3 "$d/stderr.txt"; }
    rm -f "$d"/*.exr
  done
  python3 - "$out/ttq" <<'PY' | tee "$out/ttq.md"
import json, os, sys
root = sys.argv[1]
def label(t):
    how = t.get("how")
    if how == "not_reached": return "not reached"
    return ("<= " if how == "at_first_budget" else "") + f"{t['time_s']:.3g} s"
rows = {}
integs = []
for s in sorted(os.listdir(root)):
    p = os.path.join(root, s, "results.json")
    if not os.path.exists(p): continue
    d = json.load(open(p))
    ref = "Mitsuba 3" if d["reference"]["source"] == "file" else "candela nee"
    rows[s] = (ref, {x["integrator"]: label(x["time_to_rel_mse"]) for x in d["summary"]}, d["width"], d["height"])
    integs = integs or [x["integrator"] for x in d["summary"]]
print("| scene | size | reference | " + " | ".join(integs) + " |")
print("|---|---|---|" + "---|" * len(integs))
for s, (ref, t, w, h) in rows.items():
    print(f"| {s} | {w}x{h} | {ref} | " + " | ".join(t.get(i, "-") for i in integs) + " |")
PY
fi
