#!/usr/bin/env bash
# Node fetches and primitive tests per ray of both trees on five project scenes (lavapipe; run in the repository root after a release build).

for s in cornell shade textured_mesh whitted_classic furnace; do for a in bvh cwbvh; do
  base=$(target/release/candela render scenes/$s.json --integrator pt --accel $a --width 48 --height 48 --spp 4 --seed 1 -o /tmp/x.exr --json 2>/dev/null | python3 -c "import json,sys; print(json.load(sys.stdin)['rays'])")
  n=$(CANDELA_SHADER_DEFINES="COUNT_STEPS=1" target/release/candela render scenes/$s.json --integrator pt --accel $a --width 48 --height 48 --spp 4 --seed 1 -o /tmp/x.exr --json 2>/dev/null | python3 -c "import json,sys; print(json.load(sys.stdin)['rays'])")
  p=$(CANDELA_SHADER_DEFINES="COUNT_STEPS=2" target/release/candela render scenes/$s.json --integrator pt --accel $a --width 48 --height 48 --spp 4 --seed 1 -o /tmp/x.exr --json 2>/dev/null | python3 -c "import json,sys; print(json.load(sys.stdin)['rays'])")
  python3 -c "print('$s $a rays $base nodes/ray %.2f prims/ray %.2f' % ($n/$base, $p/$base))"
done; done
