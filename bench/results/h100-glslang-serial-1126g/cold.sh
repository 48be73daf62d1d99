. bench/gpu_env.sh
for r in 1 2 3; do
for mode in serial parallel; do
  for integ in nee bdpt vct; do
    rm -rf /tmp/xc; mkdir -p /tmp/xc
    if [ $mode = parallel ]; then export CANDELA_PARALLEL_GLSLANG=1; else unset CANDELA_PARALLEL_GLSLANG; fi
    XDG_CACHE_HOME=/tmp/xc .carry/new/candela render scenes/cornell.json --integrator $integ --width 1280 --height 720 --spp 1 -o /tmp/c.exr --json 2>/dev/null | python3 -c "import json,sys; d=json.load(sys.stdin); print('$r $mode $integ', 'kernel_s', round(d['kernel_s'],3), 'setup_s', round(d['setup_s'],3), json.dumps(d.get('kernel_build')))" | tee -a $OUT/cold.txt
  done
done
done
