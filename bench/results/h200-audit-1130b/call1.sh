# Device call 1 (session of 2026-11-30, second): a vct render of a Cornell box whose red wall is
# alpha-masked (the voxels now honour masks; this checks the kernel on the NVIDIA driver, with nee
# beside it), then random scenes against Mitsuba 3 from the fresh seed 629, and the exporter and
# round-trip audits from their fresh seeds (645, 653), each cut by its own time limit.
BIN=${BIN:-.carry/n/candela}
. bench/gpu_env.sh >/dev/null 2>&1
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
mkdir -p /tmp/mi && tar xJf .carry/mitsuba-cp312.tar.xz -C /tmp/mi && export PYTHONPATH=/tmp/mi
mkdir -p /tmp/mw/assets && cp scenes/assets/checker.png /tmp/mw/assets/ && python3 - <<'PY'
import json
s = json.load(open("scenes/cornell.json"))
s["materials"]["red"]["alpha_mask"] = {"texture": "assets/checker.png", "scale": [2, 2], "channel": "g"}
s["environment"] = {"type": "constant", "radiance": [0.5, 0.5, 0.5]}
s["film"]["width"], s["film"]["height"] = 320, 320
json.dump(s, open("/tmp/mw/masked.json", "w"))
PY
for i in vct nee; do
  $BIN render /tmp/mw/masked.json --integrator $i --spp $([ $i = vct ] && echo 64 || echo 1024) -o $OUT/masked_$i.png --json > $OUT/masked_$i.json 2>&1; echo "$i rc $?"
done
timeout ${AUDIT_S:-330} python3 tests/mitsuba/audit.py --candela $BIN --seeds ${SEEDS:-629:700} --size 64 --spp 4096 --mitsuba-spp 4096 --variant cuda_ad_rgb --out /tmp/b > $OUT/audit.txt 2>&1
cp /tmp/b/audit.jsonl $OUT/; tail -3 $OUT/audit.txt | cut -c1-600
timeout ${EXPORT_S:-120} python3 tests/mitsuba/audit.py --candela $BIN --seeds ${XSEEDS:-645:700} --integrators export --size 64 --spp 4096 --mitsuba-spp 4096 --variant cuda_ad_rgb --out /tmp/x > $OUT/export.txt 2>&1
cp /tmp/x/audit.jsonl $OUT/export.jsonl; tail -2 $OUT/export.txt | cut -c1-400
