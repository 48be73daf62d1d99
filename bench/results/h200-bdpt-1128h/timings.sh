#!/usr/bin/env bash
# bdpt's light and camera passes' GPU time (report details.timings_ms) per binary in $BINS, Cornell 1280x720.
set -u
. bench/gpu_env.sh
for b in $BINS; do
  $b render scenes/cornell.json --integrator bdpt --width 1280 --height 720 --time 1 --warmup 0.3 --json -o /tmp/x.exr > /tmp/r.json 2>/dev/null
  python3 -c "import json; d=json.load(open('/tmp/r.json')); print('$b', round(d['msamples_per_s'],1), d['spp'], d.get('details',{}).get('timings_ms'))"
done
