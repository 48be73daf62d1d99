#!/usr/bin/env bash
# The measurements of issue 13 ("the first 100 ms") on an NVIDIA GPU machine (see
# ../../shared/gpu/README.md), for one binary:
#   bash bench/gpu_first100ms.sh BIN OUT [--base] [PARTS]
# PARTS (comma-separated, default all): vct (stage timings, first and later frames, option
# variants), vctq (vct's error against time with all cones or one cone per sample), bdpt (the
# split and per-pixel designs), throughput (pt/nee/bdpt at 1280x720 max_depth 6; nee at 256x256
# and 1280x720 on four scenes), bench (`candela bench` GPU busy fraction at short budgets,
# 256x256 and 1280x720), server (bench/server_latency.py: POST -> first snapshot, busy per
# integrator and budget, snapshot cadence; the driver's own shader cache is off there
# (__GL_SHADER_DISK_CACHE=0), so "cold" is cold). --base: a binary from before issue 13.
# GPU clocks are sampled every 50 ms into OUT/clocks.csv while it runs.
set -u
bin=$1 out=$2
base=${3:-}
parts=${4:-vct,vctq,bdpt,throughput,bench,server}
[ "$base" = "--base" ] || { parts=${3:-$parts}; base=; }
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv,noheader > "$out/gpu.txt" 2>/dev/null
nvidia-smi --query-gpu=timestamp,clocks.sm,clocks.mem,pstate,utilization.gpu,power.draw \
  --format=csv,noheader -lms 50 > "$out/clocks.csv" 2>/dev/null &
smi=$!
log() { echo "$(date +%T.%N | cut -c1-12) $*" | tee -a "$out/steps.log"; }
render() { # name, then candela render arguments
  local name=$1; shift
  log "render $name"
  timeout 120 "$bin" render "$@" -o /tmp/r.exr --no-accel-cache --json >> "$out/render.jsonl" 2>> "$out/stderr.log" ||
    echo "{\"failed\": \"$name\"}" >> "$out/render.jsonl"
}
C=scenes/cornell.json
if [[ $parts == *vct* ]]; then
  # First frame (1 spp) and 16 frames, default resolution 128 and 512; the second run of a
  # configuration finds the kernels in the on-disk cache (new binary).
  for o in '{}' '{"resolution": 512}'; do
    render "vct $o 1spp" $C --integrator vct --width 1280 --height 720 --spp 1 --options "$o"
    render "vct $o 16spp" $C --integrator vct --width 1280 --height 720 --spp 16 --options "$o"
  done
  # Where a frame's time goes: direct light only (no volume), one cone, dense storage.
  render "vct md2" $C --integrator vct --width 1280 --height 720 --spp 16 --max-depth 2
  render "vct cones1" $C --integrator vct --width 1280 --height 720 --spp 16 --options '{"cones": 1}'
  render "vct dense" $C --integrator vct --width 1280 --height 720 --spp 16 --options '{"storage": "dense"}'
  render "nee 1spp" $C --integrator nee --width 1280 --height 720 --spp 1
fi
if [[ $parts == *vctq* ]]; then
  # One cone per sample (a random run of the 6) against all 6: the same expected image; error
  # against a long 6-cone render at equal time.
  log "vctq"
  "$bin" render $C -o /tmp/vref.exr --integrator vct --width 1280 --height 720 --spp 512 > /dev/null 2>&1
  for cps in 6 1; do
    for t in 0.03 0.1 0.3; do
      "$bin" render $C -o /tmp/v.exr --integrator vct --width 1280 --height 720 --time $t \
        --options "{\"cones_per_sample\": $cps}" --json > /tmp/v.json 2>> "$out/stderr.log"
      "$bin" compare /tmp/v.exr /tmp/vref.exr --json 2>/dev/null | python3 -c "import json,sys; m=json.load(sys.stdin)['metrics']; r=json.load(open('/tmp/v.json')); print(json.dumps({'cones_per_sample': $cps, 'time': $t, 'spp': r['spp'], 'ms_per_frame': 1e3*r['gpu_time_s']/r['spp'], 'rel_mse': m['rel_mse'], 'flip': m['flip']}))" | tee -a "$out/vctq.jsonl"
    done
  done
fi
if [[ $parts == *bdpt* ]]; then
  for d in split per_pixel; do
    render "bdpt $d 720p" $C --integrator bdpt --width 1280 --height 720 --max-depth 6 --spp 64 --options "{\"design\": \"$d\"}"
    render "bdpt $d 256" $C --integrator bdpt --width 256 --height 256 --max-depth 6 --spp 256 --options "{\"design\": \"$d\"}"
  done
fi
if [[ $parts == *throughput* ]]; then
  for i in nee pt; do render "$i 720p" $C --integrator $i --width 1280 --height 720 --max-depth 6 --spp 256; done
  render "bdpt 720p" $C --integrator bdpt --width 1280 --height 720 --max-depth 6 --spp 64
  # Threads per pixel on a small film (CANDELA_MAX_LANES caps the automatic choice).
  if [ -z "$base" ]; then
    for l in 1 2 4 8; do
      CANDELA_MAX_LANES=$l render "nee 256 lanes $l" $C --integrator nee --width 256 --height 256 --spp 1024
    done
  fi
  # 256x256 against 1280x720 differs in content as well as size (a square film of the Cornell
  # box sees only the box; a 16:9 one also sees the dark space beside it, whose samples cost
  # almost nothing), so each size is also compared with the other's aspect: 256x144 and
  # 1280x1280.
  for s in cornell lights mirror_glass envmap; do
    render "nee 256 $s" scenes/$s.json --integrator nee --width 256 --height 256 --spp 1024
    render "nee 720p $s" scenes/$s.json --integrator nee --width 1280 --height 720 --spp 256
    render "nee 256x144 $s" scenes/$s.json --integrator nee --width 256 --height 144 --spp 4096
    render "nee 1280x1280 $s" scenes/$s.json --integrator nee --width 1280 --height 1280 --spp 144
  done
fi
if [[ $parts == *bench* ]]; then
  for size in 256x256 1280x720; do
    w=${size%x*} h=${size#*x}
    log "bench $size"
    timeout 150 "$bin" bench $C --integrators nee,pt,bdpt,vct --times 0.005,0.01,0.03 --repeats 2 \
      --width $w --height $h --reference-spp 64 --out "$out/bench_$size" > /dev/null 2>> "$out/stderr.log"
    rm -f "$out/bench_$size/reference.exr" "$out/bench_$size"/*.svg
  done
fi
if [[ $parts == *server* ]]; then
  log "server"
  __GL_SHADER_DISK_CACHE=0 timeout 300 python3 "$here/server_latency.py" --candela "$bin" \
    --out "$out/server" ${base:+--base} > "$out/server.log" 2>&1
fi
log "done"
kill $smi 2>/dev/null
# A short table of the render reports.
python3 - "$out/render.jsonl" <<'EOF' | tee "$out/render_summary.txt"
import json, sys
for l in open(sys.argv[1]):
    r = json.loads(l)
    if "failed" in r:
        print("FAILED", r["failed"]); continue
    d = r.get("details") or {}
    t = d.get("timings_ms", {})
    fp = r.get("first_pass") or {}
    k = r.get("kernel_build") or {}
    print(f"{r['integrator']:8} {r['width']}x{r['height']} {r['spp']:5} spp {r['time_s']:.3f} s gpu {r['gpu_time_s']:.3f} "
          f"setup {r['setup_s']:.2f} {r['msamples_per_s']:8.1f} Ms/s {r.get('rays', 0) / max(r['gpu_time_s'], 1e-9) / 1e6:7.0f} Mrays/GPU-s first {fp.get('gpu_ms', 0):.1f} ms "
          f"compile {k.get('compile_ms', 0):.0f} pipe {k.get('pipeline_ms', 0):.0f} "
          + " ".join(f"{a}={t[a]:.2f}" for a in ('voxelize', 'build', 'inject', 'filter', 'trace') if a in t)
          + f" {r.get('scene', '')}")
EOF
