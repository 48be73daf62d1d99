. bench/gpu_env.sh
B=.carry/exp/candela
for s in cornell mirror_glass; do $B render scenes/$s.json --integrator bdpt --width 64 --height 64 --spp 1 -o /tmp/w.exr >/dev/null 2>&1; done
for r in 1 2; do for s in cornell mirror_glass lights; do for mb in 192 400 1024; do
CANDELA_BDPT_LIGHT_MB=$mb $B render scenes/$s.json --integrator bdpt --width 1280 --height 720 --max-depth 6 --spp 64 -o /tmp/b.exr --json 2>>$OUT/err.log | python3 -c "
import json,sys; d=json.load(sys.stdin); t=d['details']['timings_ms']
print('$s', $mb, $r, round(d['msamples_per_s'],1), round(t['light_passes'],1), round(t['camera_passes'],1), d['passes'])" | tee -a $OUT/band.txt
done; done; done
