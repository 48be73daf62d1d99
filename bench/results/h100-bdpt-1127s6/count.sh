#!/usr/bin/env bash
# Node visits and primitive tests per ray, binary BVH against CWBVH (the COUNT_STEPS measuring
# define: the report's `rays` counts node fetches with =1, primitive tests with =2). Lavapipe is
# fine: the counts do not depend on the device. Run from the repository root.
B=${B:-target/release/candela}
for sc in cornell textured_mesh whitted_classic lights shade; do for i in nee pt; do for a in bvh cwbvh; do
  line="$sc $i $a"
  for d in "" COUNT_STEPS=1 COUNT_STEPS=2; do
    r=$(CANDELA_SHADER_DEFINES="$d" $B render scenes/$sc.json -o /tmp/c.exr --integrator $i --accel $a --width 64 --height 48 --spp 16 --seed 3 --json 2>/dev/null | python3 -c "import json,sys; print(json.load(sys.stdin)['rays'])")
    line="$line $r"
  done
  echo $line | awk '{printf "%s %s %s rays %d nodes/ray %.2f prims/ray %.2f\n", $1,$2,$3,$4,$5/$4,$6/$4}'
done; done; done
