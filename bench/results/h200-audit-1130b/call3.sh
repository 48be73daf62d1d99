# Device call 3 (session of 2026-11-30, second): is NVIDIA Nsight Compute (found at
# /usr/local/cuda/bin/ncu in call 2) able to profile candela's Vulkan compute dispatches?
mkdir -p .carry/n && xz -dc .carry/n.xz > .carry/n/candela && chmod +x .carry/n/candela
BIN=.carry/n/candela
. bench/gpu_env.sh >/dev/null 2>&1
export PATH=/usr/local/cuda/bin:$PATH
ncu --version 2>&1 | tail -2
ncu --help 2>&1 | grep -i -B1 -A3 "graphics\|vulkan\|replay-mode" | head -40
echo "--- plain kernel profiling"
timeout 150 ncu --target-processes all --launch-count 4 --metrics gpu__time_duration.sum,sm__warps_active.avg.pct_of_peak_sustained_active,l1tex__t_sector_hit_rate.pct,lts__t_sector_hit_rate.pct,smsp__average_warp_latency_issue_stalled_long_scoreboard.ratio \
  $BIN render scenes/cornell.json --integrator bdpt --width 1280 --height 720 --spp 2 -o /tmp/x.exr > $OUT/ncu_plain.txt 2>&1; echo "rc $?"
tail -40 $OUT/ncu_plain.txt | cut -c1-200
