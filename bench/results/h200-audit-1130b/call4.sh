# Device call 4 (session of 2026-11-30, second): bdpt's splat footprint (splat_window.patch,
# measuring defines; expectations in expect.txt), then the window's images against the
# committed loop's with fixed-point splats (bit-reproducible).
mkdir -p .carry/w && xz -dc .carry/w.xz > .carry/w/candela && chmod +x .carry/w/candela
LIST=bench/results/h200-audit-1130b/call4.list ROUNDS=3 TIME=0.5 WARMUP=0.3 bash bench/results/h200-constants-1128/matrix.sh 2>&1 | tail -8
cp $OUT/matrix.jsonl $OUT/splat_matrix.jsonl
for d in "" "SPLAT_WINDOW=5"; do
  CANDELA_SHADER_DEFINES=$d .carry/w/candela render scenes/cornell.json --integrator bdpt --options '{"fixed_point_splats": true}' --width 1280 --height 720 --spp 8 --seed 3 -o /tmp/i_${d:-base}.exr > /dev/null 2>&1; echo "rc $?"
done
cmp /tmp/i_base.exr /tmp/i_SPLAT_WINDOW=5.exr && echo "window: images identical (cmp)" | tee $OUT/identical.txt
.carry/w/candela compare /tmp/i_base.exr "/tmp/i_SPLAT_WINDOW=5.exr" 2>&1 | tail -3 | tee -a $OUT/identical.txt
