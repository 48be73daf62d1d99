# Device call 1 (session of 2026-11-29, seventh): seed 421 at two sample counts (is its miss
# a bias, which grows against the noise as the count grows, or the noise estimate's own
# scatter?), then fresh audit seeds from 434 until the time runs out.
BIN=${BIN:-.carry/g/candela}
. bench/gpu_env.sh >/dev/null 2>&1
mkdir -p /tmp/mi && tar xJf .carry/mitsuba-cp312.tar.xz -C /tmp/mi && export PYTHONPATH=/tmp/mi
for spp in 4096 16384; do
  echo "== seed 421, nee, $spp spp"
  VARIANT=cuda_ad_rgb ONLY=base timeout 120 python3 bench/results/h100-audit-1127s6/bisect.py 421 $BIN /tmp/b421_$spp $spp
done 2>&1 | tee $OUT/seed421.txt
timeout ${AUDIT_S:-330} python3 tests/mitsuba/audit.py --candela $BIN --seeds ${SEEDS:-434:480} --size 64 --spp 4096 --mitsuba-spp 4096 --variant cuda_ad_rgb --out /tmp/b > $OUT/audit.txt 2>&1
cp /tmp/b/*.jsonl $OUT/ 2>/dev/null; ls /tmp/b | head; tail -5 $OUT/audit.txt
