#!/usr/bin/env bash
# vct injection: its GPU time and the noise it leaves, per sample count (inject_samples K), on an
# NVIDIA GPU. For each binary of BINS (default .carry/main/candela) and resolution of RES
# (default "128 512"): Cornell 1280x720, 16 spp, seed 1, K in KS (default "4 8 16") and 1024
# (the reference: injection converged); the relMSE of each image against the same binary's
# K = 1024 image isolates the injection's noise (the trace's samples are the same for every K:
# same seed). Prints a table; JSON lines to OUT/vct_inject.jsonl.
set -u
cd "$(dirname "$0")/.."
. bench/gpu_env.sh
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
out=${OUT:-/tmp}
: > "$out/vct_inject.jsonl"
echo "| binary | R | K | inject ms | relMSE against K = 1024 |"
echo "|---|---|---|---|---|"
for bin in ${BINS:-.carry/main/candela}; do
  tag=$(echo "$bin" | tr '/.' '__')
  for r in ${RES:-128 512}; do
    for k in 1024 ${KS:-4 8 16}; do
      img=/tmp/inj_${tag}_${r}_${k}.exr
      ms=$("$bin" render scenes/cornell.json -o "$img" --integrator vct --spp 16 --seed 1 --json \
        --options "{\"resolution\": $r, \"inject_samples\": $k}" 2>/dev/null |
        python3 -c "import json,sys; print(json.load(sys.stdin)['details']['timings_ms']['inject'])")
      rel=$("$bin" compare "$img" /tmp/inj_${tag}_${r}_1024.exr --json |
        python3 -c "import json,sys; d=json.load(sys.stdin); m=d.get('metrics', d); print(m['rel_mse'])")
      echo "{\"bin\": \"$bin\", \"resolution\": $r, \"k\": $k, \"inject_ms\": $ms, \"rel_mse_vs_1024\": $rel}" >> "$out/vct_inject.jsonl"
      printf "| %s | %s | %s | %.2f | %.3g |\n" "$bin" "$r" "$k" "$ms" "$rel"
    done
  done
done
