. bench/gpu_env.sh
bin=.carry/new/candela
R="--width 1280 --height 720 --no-accel-cache"
python3 bench/make_many_lights.py 256 /tmp/ml256.json --width 1280 --height 720 > /dev/null
python3 bench/make_mesh_lights.py 10000 /tmp/ml10k.json > /dev/null
python3 bench/make_mesh_lights.py 100000 /tmp/ml100k.json > /dev/null
for sc in ml256 ml10k ml100k; do
  CANDELA_LBVH_EXP=-1 $bin render /tmp/$sc.json -o /tmp/${sc}_ref.exr --integrator nee --light-sampler bvh --max-depth 2 --time 15 $R > /dev/null
  for v in 0.25 0.0625 0.015625 0.004 0.0001 -1; do
    CANDELA_LBVH_EXP=$v $bin render /tmp/$sc.json -o /tmp/ml.exr --integrator nee --light-sampler bvh --max-depth 2 --warmup 1 --time 0.1 $R --json > /tmp/row.json
    rel=$($bin compare /tmp/ml.exr /tmp/${sc}_ref.exr --json | python3 -c "import json,sys; print(json.load(sys.stdin)['metrics']['rel_mse'])")
    python3 -c "import json; d=json.load(open('/tmp/row.json')); print('$sc c $v', d['spp'], round(d['msamples_per_s'],1), '%.3e' % $rel)" | tee -a $OUT/exp.txt
  done
  $bin render /tmp/$sc.json -o /tmp/ml.exr --integrator nee --light-sampler power --max-depth 2 --warmup 1 --time 0.1 $R --json > /tmp/row.json
  rel=$($bin compare /tmp/ml.exr /tmp/${sc}_ref.exr --json | python3 -c "import json,sys; print(json.load(sys.stdin)['metrics']['rel_mse'])")
  python3 -c "import json; d=json.load(open('/tmp/row.json')); print('$sc power', d['spp'], round(d['msamples_per_s'],1), '%.3e' % $rel)" | tee -a $OUT/exp.txt
done
