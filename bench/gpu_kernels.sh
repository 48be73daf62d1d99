#!/usr/bin/env bash
# On the NVIDIA GPU machine (../shared/gpu/README.md): (1) Cornell box throughput of two builds
# side by side (.carry/base/candela, e.g. the commit before a refactor, and .carry/main/candela),
# nee/pt/bdpt at 1280x720, max_depth 6, alternating, 2 repeats each; (2) specialised against
# generic kernels for every project scene and integrator (bench/kernels.py) with the main build.
# (The render's constants, old build against new on every scene, were measured with
# bench/results/h200-constants-1128/matrix.sh.)
# PARTS (default "cornell kernels") picks the parts.
# Writes OUT/cornell.jsonl, OUT/kernels.jsonl and OUT/kernels.md; prints the tables.
set -u
cd "$(dirname "$0")/.."
. bench/gpu_env.sh
out=${OUT:-/tmp}
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$out/gpu.txt"
parts=${PARTS:-cornell kernels}
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
