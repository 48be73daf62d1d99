# Device call 3 (session of 2026-11-30): the Mitsuba exporter audited on random scenes:
# `candela convert scene.json scene.xml` rendered by Mitsuba against tests/mitsuba/ref_scene.py's
# translation rendered by Mitsuba (audit.py --integrators export), seeds from 558.
BIN=${BIN:-.carry/h/candela}
. bench/gpu_env.sh >/dev/null 2>&1
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
mkdir -p /tmp/mi && tar xJf .carry/mitsuba-cp312.tar.xz -C /tmp/mi && export PYTHONPATH=/tmp/mi
timeout ${AUDIT_S:-450} python3 tests/mitsuba/audit.py --candela $BIN --seeds ${SEEDS:-558:660} --integrators export --size 64 --spp 4096 --mitsuba-spp 4096 --variant cuda_ad_rgb --out /tmp/b > $OUT/audit.txt 2>&1
cp /tmp/b/audit.jsonl $OUT/; tail -3 $OUT/audit.txt | cut -c1-600
