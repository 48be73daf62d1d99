#!/usr/bin/env bash
# Masked emitters on the GPU (session of 2026-11-27, seventh): the test scene of
# tests/tests/correctness.rs `masked_emitters_light_only_where_they_exist` at 256×256, each
# integrator's image mean against pt's (pt finds light only by hitting it), and the pt image
# without the mask; then the random-scene audit against Mitsuba 3 (alpha masks among the
# features). Usage, on the device in the repo root: BIN=.carry/X/candela OUT=dir bash run.sh
set -u
BIN=${BIN:?}; OUT=${OUT:?}; mkdir -p "$OUT/mask"
D=$(dirname "$0")
cp tests/import/mitsuba/mask.png "$OUT/mask/"
for lamp in quad sphere; do
  if [ $lamp = quad ]; then
    L='{"type": "quad", "origin": [-1, 1.5, -1], "edge_u": [2, 0, 0], "edge_v": [0, 0, 2], "material": "lamp"}'
  else
    L='{"type": "sphere", "center": [0, 1.2, 0], "radius": 0.6, "material": "lamp"}'
  fi
  for m in masked whole; do
    F=""; [ $m = masked ] && F=', "alpha_mask": {"texture": "mask.png", "scale": [2, 2]}'
    cat > "$OUT/mask/${lamp}_$m.json" <<J
{"version": 1, "camera": {"position": [0, 0.8, 3], "look_at": [0, 0, 0], "fov_y": 35},
 "film": {"width": 256, "height": 256, "filter": "box"},
 "materials": {"floor": {"type": "diffuse", "reflectance": [0.8, 0.8, 0.8]},
   "lamp": {"type": "diffuse", "reflectance": 0, "emission": [4, 4, 4]$F}},
 "objects": [{"type": "quad", "origin": [-3, 0, 3], "edge_u": [6, 0, 0], "edge_v": [0, 0, -6], "material": "floor"}, $L],
 "render": {"max_depth": 2}}
J
  done
  for run in "masked pt 3" "whole pt 1" "masked nee 1" "masked bdpt 1" "masked whitted 1" "masked deferred 1" "whole deferred 1"; do
    set -- $run
    "$BIN" render "$OUT/mask/${lamp}_$1.json" --integrator $2 --time $3 -o "$OUT/mask/${lamp}_$1_$2.exr" --json > "$OUT/mask/${lamp}_$1_$2.json" 2> "$OUT/mask/${lamp}_$1_$2.err" || echo "FAILED $lamp $run"
  done
  python3 "$D/means.py" "$OUT/mask" $lamp | tee -a "$OUT/means.txt"
done
if [ -n "${AUDIT:-}" ]; then
  python3 tests/mitsuba/audit.py --candela "$BIN" --seeds "$AUDIT" --size 64 --spp 4096 --mitsuba-spp 4096 --variant cuda_ad_rgb --out "$OUT/audit" > "$OUT/audit.txt" 2>&1
  tail -n 30 "$OUT/audit.txt"
fi
