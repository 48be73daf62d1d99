# Node visits and primitive tests per ray (COUNT_STEPS) of the binary BVH for leaf sizes and collapse costs (lavapipe; run from the repository root).
B=target/release/candela
for sc in cornell textured_mesh whitted_classic shade mirror_glass; do for kn in "4 3" "2 3" "1 3" "4 1" "4 6"; do
  set -- $kn
  line="$sc leaf$1 cost$2"
  for d in "" COUNT_STEPS=1 COUNT_STEPS=2; do
    r=$(CANDELA_BVH_LEAF=$1 CANDELA_COLLAPSE_COST=$2 CANDELA_SHADER_DEFINES="$d" $B render scenes/$sc.json -o /tmp/c.exr --integrator nee --accel bvh --no-accel-cache --width 64 --height 48 --spp 16 --seed 3 --json 2>/dev/null | python3 -c "import json,sys; d=json.load(sys.stdin); print(d['rays'], d['bvh_nodes'])")
    line="$line $r"
  done
  echo $line | awk '{printf "%s %s %s rays %d bvh_nodes %d nodes/ray %.2f prims/ray %.2f\n", $1,$2,$3,$4,$5,$6/$4,$8/$4}'
done; done
