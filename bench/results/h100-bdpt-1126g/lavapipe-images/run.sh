#!/bin/bash
# usage: run.sh BIN OUTDIR
BIN=$1; OUT=$2; mkdir -p $OUT
r() { name=$1; scene=$2; opts=$3; $BIN render scenes/$scene.json --integrator bdpt --options "$opts" --spp 8 --width 24 --height 24 --seed 3 -o $OUT/$name.exr > $OUT/$name.log 2>&1 || echo "FAIL $name"; }
r cornell5 cornell '{"max_depth":5,"fixed_point_splats":true}'
r cornell5pp cornell '{"max_depth":5,"fixed_point_splats":true,"design":"per_pixel"}'
r cornell5nomis cornell '{"max_depth":5,"fixed_point_splats":true,"mis":false}'
r mirror6 mirror_glass '{"max_depth":6,"fixed_point_splats":true}'
r lights5 lights '{"max_depth":5,"fixed_point_splats":true}'
r envmap5 envmap '{"max_depth":5,"fixed_point_splats":true}'
r thinlens5 thinlens '{"max_depth":5,"fixed_point_splats":true}'
r shade6 shade '{"max_depth":6,"fixed_point_splats":true}'
r textured5 textured_mesh '{"max_depth":5,"fixed_point_splats":true}'
