#!/usr/bin/env bash
# Runs the benchmark set on an NVIDIA GPU machine (see ../../shared/gpu/README.md): candela's
# pt and nee on the Cornell box at 1280x720, max_depth 6, the other example scenes, a Cornell box
# with a ~2M-triangle mesh, and Mitsuba 3 (cuda_ad_rgb) on its own Cornell box for comparison.
# Expects .carry/candela (release build) and optionally .carry/mitsuba-cp312.tar.xz.
# Writes JSON lines to ${OUT:-/tmp}/bench.jsonl and prints them.
set -u
cd "$(dirname "$0")/.."
. bench/gpu_env.sh
out=${OUT:-/tmp}/bench.jsonl
: > "$out"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "${OUT:-/tmp}/gpu.txt"
bin=.carry/candela
$bin devices
run() { $bin render "$@" --json | tee -a "$out"; }
for integ in nee pt bdpt; do
  run scenes/cornell.json -o /tmp/cornell_$integ.exr --integrator $integ --width 1280 --height 720 --max-depth 6 --spp 1024
done
run scenes/cornell.json -o /tmp/cornell_time.exr --integrator nee --width 1280 --height 720 --max-depth 6 --time 5
for s in mirror_glass lights textured_mesh envmap; do
  run scenes/$s.json -o /tmp/$s.exr --integrator nee --width 1280 --height 720 --spp 256
done
python3 bench/make_big_scene.py /tmp/big --triangles 2000000
run /tmp/big/big.json -o /tmp/big.exr --integrator nee --width 1280 --height 720 --max-depth 6 --spp 256
# Error against time (issue 7): pt, nee and bdpt on the Cornell box at 1280x720, 3 repeats.
.carry/candela bench scenes/cornell.json --integrators pt,nee,bdpt --times 0.01,0.03,0.1,0.3,1,3 \
  --repeats 3 --width 1280 --height 720 --reference-spp 65536 --out "${OUT:-/tmp}/cornell-bench"
rm -f "${OUT:-/tmp}/cornell-bench/reference.exr"
if [ -f .carry/mitsuba-cp312.tar.xz ]; then
  mkdir -p /tmp/mi && tar xJf .carry/mitsuba-cp312.tar.xz -C /tmp/mi
  PYTHONPATH=/tmp/mi python3 bench/mitsuba_cornell.py --variant cuda_ad_rgb --width 1280 --height 720 --spp 256 --max-depth 6 | tee -a "$out"
fi
# Grid vs BVH (docs/accel.md), opt-in: ACCEL_BENCH=1 bash bench/gpu_run.sh
if [ -n "${ACCEL_BENCH:-}" ]; then
  python3 bench/accel_grid.py --candela $bin --out "${OUT:-/tmp}/accel_grid"
fi
