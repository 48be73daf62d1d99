. bench/gpu_env.sh
B=.carry/exp/candela
for s in cornell mirror_glass; do $B render scenes/$s.json --integrator bdpt --width 64 --height 64 --spp 1 -o /tmp/w.exr >/dev/null 2>&1; done
for r in 1 2; do for s in cornell mirror_glass; do for e in 0 1 2 4 6 8 16 32 40 64; do
CANDELA_BDPT_EXP=$e $B render scenes/$s.json --integrator bdpt --width 1280 --height 720 --max-depth 6 --spp 64 -o /tmp/b.exr --json 2>>$OUT/err.log | python3 -c "
import json,sys; d=json.load(sys.stdin); t=d['details']['timings_ms']
print('$s', $e, $r, round(d['msamples_per_s'],1), round(t['light_passes'],1), round(t['camera_passes'],1), round(d['rays']/d['spp']/d['width']/d['height'],2))" | tee -a $OUT/exp.txt
done; done; done
