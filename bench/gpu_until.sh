#!/usr/bin/env bash
# Issue 14 deliver 3, the cost of a quality budget: on the NVIDIA GPU machine
# (../shared/gpu/README.md), Cornell 1280x720 max_depth 6, pt / nee / bdpt rendered with
# `--until-rel-mse T` (TARGETS, default "0.01 0.001"; capped at 30 s), then the same render with
# `--spp N` for the N it stopped at: Msamples/s of both, the checks' count, GPU time and wait
# (`estimate_checks`). Each render after a 1 s warm-up (full clocks). BINS lists the binaries
# (default .carry/main/candela, and .carry/base/candela when present: before/after in one call).
# Writes OUT/until.jsonl; prints a table. DRY=1: lavapipe, 64x36, target/debug/candela.
set -u
cd "$(dirname "$0")/.."
if [ "${DRY:-0}" = 1 ]; then
  bins=${BINS:-target/debug/candela}; R="--width 64 --height 36"; warm=0
else
  for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
  bins=${BINS:-.carry/main/candela $( [ -x .carry/base/candela ] && echo .carry/base/candela)}
  R="--width 1280 --height 720"; warm=1
fi
out=${OUT:-/tmp}
jsonl="$out/until.jsonl"
: > "$jsonl"
for bin in $bins; do
  for integ in pt nee bdpt; do
    for target in ${TARGETS:-0.01 0.001}; do
      "$bin" render scenes/cornell.json -o /tmp/u.exr --integrator $integ --max-depth 6 $R \
        --warmup $warm --until-rel-mse $target --time 30 --json > /tmp/u.json || continue
      spp=$(python3 -c "import json; print(json.load(open('/tmp/u.json'))['spp'])")
      "$bin" render scenes/cornell.json -o /tmp/s.exr --integrator $integ --max-depth 6 $R \
        --warmup $warm --spp $spp --json > /tmp/s.json || continue
      python3 - "$bin" $integ $target >> "$jsonl" <<'PY'
import json, sys
u, s = json.load(open("/tmp/u.json")), json.load(open("/tmp/s.json"))
keep = ("spp", "time_s", "msamples_per_s", "rel_mse_estimate", "stopped_by", "estimate_checks")
print(json.dumps({"bin": sys.argv[1], "integrator": sys.argv[2], "target": float(sys.argv[3]),
                  "until": {k: u.get(k) for k in keep}, "spp_only": {k: s.get(k) for k in keep}}))
PY
    done
  done
done
python3 - "$jsonl" <<'PY'
import json, sys
print("| binary | integrator | target | stopped at spp | until: Msamples/s | checks (GPU ms / wait ms) | same spp without target: Msamples/s | ratio |")
print("|---|---|---|---|---|---|---|---|")
for l in open(sys.argv[1]):
    d = json.loads(l); u, s = d["until"], d["spp_only"]
    c = u.get("estimate_checks") or {}
    print(f"| {d['bin']} | {d['integrator']} | {d['target']} | {u['spp']} | {u['msamples_per_s']:.1f} | "
          f"{c.get('checks', '-')} ({c.get('gpu_ms', 0):.2f} / {c.get('wait_ms', 0):.2f}) | "
          f"{s['msamples_per_s']:.1f} | {u['msamples_per_s'] / s['msamples_per_s']:.2f} |")
PY
