# Call 4 (the first sweep of the importance's distance floor; a temporary define LBVH_EXP set by
# CANDELA_LBVH_EXP, not committed): 0 = d² ≥ (diagonal/2)² (then current), 1 = pbrt-v4's
# d² ≥ |diagonal|/2, 2 = d² ≥ (diagonal/4)²; relMSE against a 30 s render of variant 0.
# Reconstructed from the session log; the same as the script that ran.
. bench/gpu_env.sh
bin=.carry/new/candela
R="--width 1280 --height 720 --no-accel-cache"
python3 bench/make_many_lights.py 256 /tmp/ml.json --width 1280 --height 720 > /dev/null
$bin render /tmp/ml.json -o /tmp/ml_ref.exr --integrator nee --light-sampler bvh --max-depth 2 --time 30 $R > /dev/null
for v in 0 1 2; do
  for t in 0.1 0.1 0.1 1; do
    for seed in 1 2; do
    CANDELA_LBVH_EXP=$v $bin render /tmp/ml.json -o /tmp/ml.exr --integrator nee --light-sampler bvh --max-depth 2 --warmup 1 --time $t --seed $seed $R --json > /tmp/row.json
    rel=$($bin compare /tmp/ml.exr /tmp/ml_ref.exr --json | python3 -c "import json,sys; print(json.load(sys.stdin)['metrics']['rel_mse'])")
    python3 -c "import json; d=json.load(open('/tmp/row.json')); print('variant $v t $t seed $seed', d['spp'], round(d['msamples_per_s'],1), '%.3e' % $rel)" | tee -a $OUT/exp.txt
    done
  done
done
