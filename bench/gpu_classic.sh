#!/usr/bin/env bash
# The GPU measurements of the fast modes (issues 5 and 6) on an NVIDIA machine (see
# ../../shared/gpu/README.md), in parts that each fit one 10-minute device call:
#   bash bench/gpu_classic.sh quality   each mode's error against a nee reference, Cornell box
#   bash bench/gpu_classic.sh deferred  deferred at 1..10,000 lights, 1920x1080 (deferred_lights.sh)
#   bash bench/gpu_classic.sh grid      whitted with the BVH against uniform grids (accel_grid.py)
#   bash bench/gpu_classic.sh vct       vct stage timings and memory at 2^8..2^10 (octree and dense)
#   bash bench/gpu_classic.sh vct_depth vct against nee at the same max_depth (3, and 4 with 2 bounces)
# Expects .carry/candela (release build) and .carry/COMMIT (the commit it was built from).
# Results go to ${OUT:-/tmp}/<part>/.
set -u
cd "$(dirname "$0")/.."
part=${1:?usage: gpu_classic.sh quality|deferred|grid|vct|vct_depth}
if [ -d .gl ]; then
  for f in .gl/*.deb; do dpkg -x "$f" /; done
  ldconfig
  export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
fi
bin=${CANDELA:-.carry/candela}
CANDELA_COMMIT=$(cat .carry/COMMIT 2>/dev/null || echo unknown)
export CANDELA_COMMIT
out=${OUT:-/tmp}/$part
mkdir -p "$out"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>/dev/null
echo "commit $CANDELA_COMMIT" >> "$out/gpu.txt"
cat "$out/gpu.txt"
W=1280 H=720

# One render with its JSON report kept: name, scene, then candela render arguments.
render() {
  local name=$1 scene=$2
  shift 2
  $bin render "$scene" -o "$out/$name.exr" --width $W --height $H --json "$@" > "$out/$name.json" ||
    echo "FAILED: $name" >&2
}
# Error of a render against a reference, as one JSON line (image name, metrics).
compare() {
  $bin compare "$out/$1.exr" "$out/$2.exr" --json |
    python3 -c "import json,sys; m=json.load(sys.stdin); m['image']='$1'; m['reference']='$2'; print(json.dumps(m))" |
    tee -a "$out/quality.jsonl"
}

case $part in
quality)
  # References: nee with the scene's depth, and nee at max_depth 2 (direct light only, what
  # deferred computes). 16,384 spp at 1280x720 takes about 15 s on an H200.
  render ref_nee scenes/cornell.json --integrator nee --spp 16384
  render ref_nee_direct scenes/cornell.json --integrator nee --max-depth 2 --spp 16384
  render whitted scenes/cornell.json --integrator whitted --spp 64
  render deferred scenes/cornell.json --integrator deferred --spp 64
  render deferred_shadows scenes/cornell.json --integrator deferred --spp 64 --options '{"shadows": true}'
  for r in 128 256 512; do
    render vct_$r scenes/cornell.json --integrator vct --spp 64 --options "{\"resolution\": $r}"
  done
  render vct_256_dense scenes/cornell.json --integrator vct --spp 64 --options '{"resolution": 256, "storage": "dense"}'
  render vct_1024 scenes/cornell.json --integrator vct --spp 64 --options '{"resolution": 1024}'
  # How the cones' coarsest level (max_level, default log2(R) - 4) and step move the error.
  render vct_512_ml6 scenes/cornell.json --integrator vct --spp 64 --options '{"resolution": 512, "max_level": 6}'
  render vct_512_ml4 scenes/cornell.json --integrator vct --spp 64 --options '{"resolution": 512, "max_level": 4}'
  render vct_512_step025 scenes/cornell.json --integrator vct --spp 64 --options '{"resolution": 512, "step": 0.25}'
  render vct_128_ml2 scenes/cornell.json --integrator vct --spp 64 --options '{"resolution": 128, "max_level": 2}'
  render vct_512_b2 scenes/cornell.json --integrator vct --spp 64 --options '{"resolution": 512, "bounces": 2}'
  render nee_64 scenes/cornell.json --integrator nee --spp 64
  : > "$out/quality.jsonl"
  for m in whitted deferred deferred_shadows vct_128 vct_128_ml2 vct_256 vct_256_dense vct_512 vct_512_ml4 vct_512_ml6 vct_512_step025 vct_1024 vct_512_b2 nee_64; do
    compare $m ref_nee
  done
  compare deferred ref_nee_direct
  compare deferred_shadows ref_nee_direct
  for f in "$out"/*.json; do
    python3 -c "import json,sys; r=json.load(open(sys.argv[1])); print(sys.argv[1].split('/')[-1], r['integrator'], r['spp'], 'spp', round(r['time_s'],3), 's', round(r['msamples_per_s'],1), 'Msamples/s')" "$f"
  done
  rm -f "$out"/*.exr
  ;;
vct_depth)
  # vct models paths of at most 3 segments with 1 bounce (4 with 2): against nee at the same
  # max_depth its error is its own approximation, not the light of the missing bounces.
  : > "$out/quality.jsonl"
  render ref_nee_d3 scenes/cornell.json --integrator nee --max-depth 3 --spp 16384
  render ref_nee_d4 scenes/cornell.json --integrator nee --max-depth 4 --spp 16384
  for r in 128 256 512 1024; do
    render vct3_$r scenes/cornell.json --integrator vct --spp 64 --max-depth 3 --options "{\"resolution\": $r}"
    compare vct3_$r ref_nee_d3
  done
  render vct4_512_b2 scenes/cornell.json --integrator vct --spp 64 --max-depth 4 --options '{"resolution": 512, "bounces": 2}'
  compare vct4_512_b2 ref_nee_d4
  rm -f "$out"/*.exr
  ;;
deferred)
  bash bench/deferred_lights.sh --candela "$bin" --width 1920 --height 1080 --spp 16 --out "$out/no_shadows"
  bash bench/deferred_lights.sh --candela "$bin" --width 1920 --height 1080 --spp 16 \
    --options '{"shadows": true}' --out "$out/shadows"
  rm -f "$out"/*/*.exr
  ;;
grid)
  python3 bench/accel_grid.py --candela "$bin" --integrator whitted --width $W --height $H \
    --spp 64 --grids auto,32,64,128,256 --repeats 3 --out "$out"
  rm -rf "$out"/big "$out"/*.exr
  ;;
vct)
  # Stage timings and memory (details in the JSON report): octree at 2^10, 2^9 and 2^8, dense
  # (capped at 2^8) at 2^8, on the repository's scenes and a 1M-triangle mesh.
  python3 bench/make_big_scene.py /tmp/big --triangles 1000000 > /dev/null
  for scene in scenes/textured_mesh.json scenes/cornell.json /tmp/big/big.json; do
    s=$(basename "$scene" .json)
    for cfg in octree:1024 octree:512 octree:256 dense:256; do
      storage=${cfg%:*} res=${cfg#*:}
      name=vct_${s}_${storage}_$res
      render $name "$scene" --integrator vct --spp 16 \
        --options "{\"resolution\": $res, \"storage\": \"$storage\"}"
      python3 -c "import json,sys; r=json.load(open(sys.argv[1])); print(sys.argv[2], json.dumps({k: r.get(k) for k in ('time_s','gpu_time_s','setup_s','triangles','details')}))" "$out/$name.json" $name
    done
  done
  rm -f "$out"/*.exr
  ;;
*)
  echo "unknown part $part" >&2
  exit 2
  ;;
esac
