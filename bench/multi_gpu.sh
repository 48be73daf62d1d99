#!/usr/bin/env bash
# Multi-GPU scaling of one render (issue 15, deliver 8): Cornell at WIDTHxHEIGHT (default
# 3840x2160), nee, max_depth 6, for TIME seconds (default 10) on 1 device (--devices 0), on 2 and
# 4 where there are that many (--devices 0,1 / 0,1,2,3) and on every device (--devices all),
# after a 2-second warm-up on each; REPEATS (default 2) rounds, alternating. CONFIGS overrides
# the device lists (space-separated, e.g. "0 0,1"). Prints Msamples/s of each run and per
# device, and each list's scaling factor against 1 device (best run of each).
# Writes OUT/multi_gpu.jsonl (one candela --json report per run, with "config": the list).
#
# On the NVIDIA GPU machine (../shared/gpu/README.md) it uses .carry/main/candela and the NVIDIA
# Vulkan driver. Elsewhere set CANDELA (binary) and, to try it on lavapipe with two contexts on
# the one CPU device, CONFIGS="0 0,0" WIDTH=64 HEIGHT=64 TIME=0.5 WARMUP=0.
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
mkdir -p "$out"
jsonl="$out/multi_gpu.jsonl"
: > "$jsonl"
"$bin" devices
if [ -z "${CONFIGS:-}" ]; then
  n=$("$bin" devices --json | python3 -c "import json,sys; print(sum(d['kind'] == 'discrete' for d in json.load(sys.stdin)))")
  CONFIGS="0"
  [ "$n" -ge 2 ] && CONFIGS="$CONFIGS 0,1"
  [ "$n" -ge 4 ] && CONFIGS="$CONFIGS 0,1,2,3"
  [ "$n" -ne 1 ] && [ "$n" -ne 2 ] && [ "$n" -ne 4 ] && CONFIGS="$CONFIGS all"
fi
for rep in $(seq "$repeats"); do
  for devices in $CONFIGS; do
    config=$devices
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
          f"| {r["msamples_per_s"]:.2f} | {per} |")
configs = list(dict.fromkeys(r["config"] for r in rows))
best = {c: max(r["msamples_per_s"] for r in rows if r["config"] == c) for c in configs}
one = best[configs[0]]
for c in configs:
    n = len(next(r for r in rows if r["config"] == c)["devices"])
    scale = best[c] / one if one > 0 else float("nan")
    print(f"scaling --devices {c}: {best[c]:.2f} / {one:.2f} Msamples/s = {scale:.2f}x on {n} "
          f"devices ({scale / n:.2f} of linear; target >= 0.9)")
    print(json.dumps({"config": c, "devices": n, "msamples_per_s": best[c],
                      "one_msamples_per_s": one, "scaling": scale}))
EOF
