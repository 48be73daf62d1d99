#!/usr/bin/env bash
# On the NVIDIA GPU machine (../shared/gpu/README.md): (1) Cornell box throughput of two builds
# side by side (.carry/base/candela, e.g. the commit before a refactor, and .carry/main/candela),
# nee/pt/bdpt at 1280x720, max_depth 6, alternating, 2 repeats each; (2) specialised against
# generic kernels for every project scene and integrator (bench/kernels.py) with the main build;
# (3) the main build with max_depth and rr_depth compiled in as constants (CANDELA_DEPTH_CONSTANTS=1)
# against push constants, Cornell 1280x720, pt and nee at max_depth 6 and 12, alternating, 3 repeats.
# PARTS (default "cornell kernels depth") picks the parts.
# Writes OUT/cornell.jsonl, OUT/kernels.jsonl, OUT/kernels.md and OUT/depth.jsonl; prints the tables.
set -u
cd "$(dirname "$0")/.."
. bench/gpu_env.sh
out=${OUT:-/tmp}
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$out/gpu.txt"
parts=${PARTS:-cornell kernels depth}
has() { case " $parts " in *" $1 "*) return 0;; esac; return 1; }
: > "$out/cornell.jsonl"
if has cornell && [ -x .carry/base/candela ]; then
  for rep in 1 2; do
    for integ in nee pt bdpt; do
      for build in base main; do
        # Builds without --warmup get a 1-second render first, in its own process.
        if .carry/$build/candela render --help | grep -q -- --warmup; then warm="--warmup 1"; else
          warm=""; .carry/$build/candela render scenes/cornell.json -o /tmp/c.exr --integrator $integ \
            --width 1280 --height 720 --max-depth 6 --time 1 --no-accel-cache > /dev/null; fi
        .carry/$build/candela render scenes/cornell.json -o /tmp/c.exr --integrator $integ \
          --width 1280 --height 720 --max-depth 6 $warm --time 3 --no-accel-cache --json \
          | python3 -c "import json,sys; d=json.load(sys.stdin); d['build']='$build'; print(json.dumps(d))" \
          >> "$out/cornell.jsonl"
      done
    done
  done
  python3 - "$out/cornell.jsonl" <<'EOF'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
print("| integrator | build | Msamples/s (each run) |")
print("|---|---|---|")
for integ in ("nee", "pt", "bdpt"):
    for build in ("base", "main"):
        v = [r["msamples_per_s"] for r in rows if r["integrator"] == integ and r["build"] == build]
        print(f"| {integ} | {build} | {', '.join(f'{x:.1f}' for x in v)} |")
EOF
fi
has kernels && python3 bench/kernels.py --candela .carry/main/candela --out "$out" \
  --time "${KERNELS_TIME:-0.5}" | tee "$out/kernels.md"
if has depth; then
  : > "$out/depth.jsonl"
  for rep in 1 2 3; do
    for md in 6 12; do
      for integ in nee pt; do
        for consts in 0 1; do
          CANDELA_DEPTH_CONSTANTS=$consts .carry/main/candela render scenes/cornell.json -o /tmp/c.exr \
            --integrator $integ --width 1280 --height 720 --max-depth $md --warmup 1 --time 2 \
            --no-accel-cache --json | python3 -c "import json,sys; d=json.load(sys.stdin); \
d['depth_constants']=$consts; print(json.dumps(d))" >> "$out/depth.jsonl"
        done
      done
    done
  done
  python3 - "$out/depth.jsonl" <<'EOF'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
print("| integrator | max_depth | push constants (Msamples/s) | compiled in | ratio |")
print("|---|---|---|---|---|")
for integ in ("nee", "pt"):
    for md in (6, 12):
        v = {c: [r["msamples_per_s"] for r in rows if r["integrator"] == integ
                 and r["max_depth"] == md and r["depth_constants"] == c] for c in (0, 1)}
        med = {c: sorted(x)[len(x) // 2] for c, x in v.items()}
        print(f"| {integ} | {md} | {', '.join(f'{x:.1f}' for x in v[0])} | "
              f"{', '.join(f'{x:.1f}' for x in v[1])} | {med[1] / med[0]:.3f} |")
EOF
fi
