# Device call 2 (session of 2026-11-29, seventh): with uv-less meshes read in Mitsuba's
# orientation, the audit's seed 441 again, then fresh seeds from 459 until the time runs out.
BIN=${BIN:-.carry/g/candela}
. bench/gpu_env.sh >/dev/null 2>&1
mkdir -p /tmp/mi && tar xJf .carry/mitsuba-cp312.tar.xz -C /tmp/mi && export PYTHONPATH=/tmp/mi
timeout 60 python3 tests/mitsuba/audit.py --candela $BIN --seeds 441:442 --size 64 --spp 4096 --mitsuba-spp 4096 --variant cuda_ad_rgb --out /tmp/b441 > $OUT/seed441.txt 2>&1
cp /tmp/b441/audit.jsonl $OUT/seed441_fixed.jsonl
timeout ${AUDIT_S:-420} python3 tests/mitsuba/audit.py --candela $BIN --seeds ${SEEDS:-459:520} --size 64 --spp 4096 --mitsuba-spp 4096 --variant cuda_ad_rgb --out /tmp/b > $OUT/audit.txt 2>&1
cp /tmp/b/audit.jsonl $OUT/; cat $OUT/seed441.txt | cut -c1-300; tail -3 $OUT/audit.txt | cut -c1-400
