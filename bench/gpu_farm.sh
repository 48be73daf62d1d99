#!/usr/bin/env bash
# Issue 15 on a multi-GPU NVIDIA machine (run's kind nvidia-h100-x2 or larger; carry .gl and
# .carry with .carry/main/candela and .carry/pg15.tar.xz from bench/pg-pack.sh): one Cornell job
# of SPP (default 1024) spp at 3840x2160 through the farm — PostgreSQL, `serve --workers 0`, one
# `candela worker --devices LIST --shard-spp SHARD` (default 128) — for each list of CONFIGS
# (default "0 0,1"; bench/farm_scaling.py), FARM_REPEATS rounds of them (default 1; the table
# gives each run and the medians), and, for comparison, the same film rendered in one
# process with `render --devices` (bench/multi_gpu.sh, TIME seconds each; MULTI=0 skips it). BIN
# picks the binary of the farm (default .carry/main/candela). Writes OUT/farm.json,
# OUT/multi_gpu.jsonl and the farm logs.
set -u
cd "$(dirname "$0")/.."
. bench/gpu_env.sh
nvidia-smi --query-gpu=index,name,driver_version --format=csv,noheader
tar xJf .carry/pg15.tar.xz -C / --no-overwrite-dir
export LD_LIBRARY_PATH=/opt/pglibs  # PostgreSQL's; farm_scaling.py drops it for candela
out=${OUT:-/tmp}
python3 bench/farm_scaling.py --candela ${BIN:-.carry/main/candela} --configs ${CONFIGS:-0 0,1} \
  --spp ${SPP:-1024} --shard-spp ${SHARD:-128} --repeats ${FARM_REPEATS:-1} --out "$out"
unset LD_LIBRARY_PATH
[ "${MULTI:-1}" = 0 ] || CONFIGS="${CONFIGS:-0 0,1}" TIME=${TIME:-5} REPEATS=1 OUT="$out" bash bench/multi_gpu.sh | tail -6
