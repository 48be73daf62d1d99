# Device call 1 (session of 2026-11-30): random scenes whose transforms now mirror a quarter of
# the time (fresh audit seeds from 558), after the exporter / reference-translator fix for
# mirrored meshes; and a vct render of a textured sphere (its voxels now read the sphere's uv).
BIN=${BIN:-.carry/h/candela}
. bench/gpu_env.sh >/dev/null 2>&1
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
mkdir -p /tmp/mi && tar xJf .carry/mitsuba-cp312.tar.xz -C /tmp/mi && export PYTHONPATH=/tmp/mi
mkdir -p /tmp/ts && python3 - <<'PY'
import json
json.dump({"version": 1, "camera": {"position": [0, 1, 4], "look_at": [0, 0, 0], "fov_y": 40},
           "film": {"width": 320, "height": 240},
           "materials": {"c": {"type": "diffuse", "reflectance": {"texture": "checker.png"}},
                         "g": {"type": "diffuse", "reflectance": 0.5}},
           "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "c"},
                       {"type": "quad", "origin": [-3, -1, 3], "edge_u": [6, 0, 0],
                        "edge_v": [0, 0, -6], "material": "g"}],
           "environment": {"type": "constant", "radiance": [1, 1, 1]}},
          open("/tmp/ts/sphere.json", "w"))
PY
cp scenes/assets/checker.png /tmp/ts/
$BIN render /tmp/ts/sphere.json --integrator vct --spp 16 -o $OUT/vct_sphere.png --json > $OUT/vct_sphere.json 2>&1; echo "vct rc $?"
$BIN render /tmp/ts/sphere.json --integrator nee --spp 256 -o $OUT/nee_sphere.png > /dev/null 2>&1; echo "nee rc $?"
timeout ${AUDIT_S:-420} python3 tests/mitsuba/audit.py --candela $BIN --seeds ${SEEDS:-558:620} --size 64 --spp 4096 --mitsuba-spp 4096 --variant cuda_ad_rgb --out /tmp/b > $OUT/audit.txt 2>&1
cp /tmp/b/audit.jsonl $OUT/; tail -3 $OUT/audit.txt | cut -c1-600
