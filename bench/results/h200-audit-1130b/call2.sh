# Device call 2 (session of 2026-11-30, second): random scenes against Mitsuba 3 from the fresh
# seed 655 and round trips from 653 (build n = f46f52b), and what the driver reports about bdpt's
# two kernels (VK_KHR_pipeline_executable_properties, every statistic) and whether NVIDIA's
# profilers are installed.
mkdir -p .carry/n && xz -dc .carry/n.xz > .carry/n/candela && chmod +x .carry/n/candela
BIN=.carry/n/candela
. bench/gpu_env.sh >/dev/null 2>&1
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee $OUT/gpu.txt
echo "profilers: $(command -v ncu nsys nvcc nv-nsight-cu-cli 2>/dev/null | tr '\n' ' ')"
$BIN render scenes/cornell.json --integrator bdpt --width 1280 --height 720 --time 0.3 -o /tmp/x.exr --json > /tmp/b.json 2>/dev/null
python3 -c "import json; d=json.load(open('/tmp/b.json')); print(json.dumps({k: d[k] for k in d if 'kernel' in k}))" | tee $OUT/bdpt_kernel_stats.json | cut -c1-1500
mkdir -p /tmp/mi && tar xJf .carry/mitsuba-cp312.tar.xz -C /tmp/mi && export PYTHONPATH=/tmp/mi
timeout ${AUDIT_S:-300} python3 tests/mitsuba/audit.py --candela $BIN --seeds ${SEEDS:-655:720} --size 64 --spp 4096 --mitsuba-spp 4096 --variant cuda_ad_rgb --out /tmp/b > $OUT/audit.txt 2>&1
cp /tmp/b/audit.jsonl $OUT/; tail -1 $OUT/audit.txt | cut -c1-300
timeout ${RT_S:-120} python3 bench/results/h200-audit-1130/roundtrip.py --candela $BIN --seeds ${RSEEDS:-653:720} --out /tmp/rt > $OUT/roundtrip.txt 2>&1
cp /tmp/rt/roundtrip.jsonl $OUT/; tail -1 $OUT/roundtrip.txt | cut -c1-300
