#!/usr/bin/env bash
# Multi-GPU scaling of one render (issue 15, deliver 8): Cornell at WIDTHxHEIGHT (default
# 3840x2160), nee, max_depth 6, for TIME seconds (default 10) on one device (--devices 0) and on
# every device (--devices all), after a 2-second warm-up on each; REPEATS (default 2) rounds,
# alternating. Prints Msamples/s of each run, per device, and the scaling factor all/one.
# Writes OUT/multi_gpu.jsonl (one candela --json report per run, with "config": "one"|"all").
#
# On the NVIDIA GPU machine (../shared/gpu/README.md) it uses .carry/main/candela and the NVIDIA
# Vulkan driver. Elsewhere set CANDELA (binary) and, to try it on lavapipe with two contexts on
# the one CPU device, DEVICES_ALL=0,0 WIDTH=64 HEIGHT=64 TIME=0.5 WARMUP=0.
set -eu
cd "$(dirname "$0")/.."
bin=${CANDELA:-.carry/main/candela}
if [ -z "${CANDELA:-}" ] && [ -d /usr/local/nvidia/share/vulkan/icd.d ]; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader || true
fi
out=${OUT:-/tmp}
width=${WIDTH:-3840}
height=${HEIGHT:-2160}
time=${TIME:-10}
warmup=${WARMUP:-2}
repeats=${REPEATS:-2}
all=${DEVICES_ALL:-all}
mkdir -p "$out"
jsonl="$out/multi_gpu.jsonl"
: > "$jsonl"
"$bin" devices
for rep in $(seq "$repeats"); do
  for config in one all; do
    devices=0
    [ "$config" = all ] && devices=$all
    "$bin" render scenes/cornell.json -o "$out/multi_gpu_$config.exr" --integrator nee \
      --width "$width" --height "$height" --max-depth 6 --warmup "$warmup" --time "$time" \
      --devices "$devices" --no-accel-cache --json \
      | python3 -c "import json,sys; d=json.load(sys.stdin); d['config']='$config'; d['repeat']=$rep; print(json.dumps(d))" \
      >> "$jsonl"
  done
done
python3 - "$jsonl" <<'EOF'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
print("| config | repeat | devices | spp | time s | Msamples/s | per device Msamples/s |")
print("|---|---|---|---|---|---|---|")
for r in rows:
    per = ", ".join(f"{d['index']}: {d['msamples_per_s']:.1f} ({d['spp']} spp)" for d in r["devices"])
    print(f"| {r['config']} | {r['repeat']} | {len(r['devices'])} | {r['spp']} | {r['time_s']:.2f} "
          f"| {r['msamples_per_s']:.1f} | {per} |")
best = {c: max(r["msamples_per_s"] for r in rows if r["config"] == c) for c in ("one", "all")}
n = len(next(r for r in rows if r["config"] == "all")["devices"])
scale = best["all"] / best["one"] if best["one"] > 0 else float("nan")
print(f"scaling: {best['all']:.1f} / {best['one']:.1f} Msamples/s = {scale:.2f}x on {n} devices "
      f"({scale / n:.2f} of linear; target >= 0.9)")
print(json.dumps({"scaling": scale, "devices": n, "one_msamples_per_s": best["one"],
                  "all_msamples_per_s": best["all"]}))
EOF
