#!/usr/bin/env bash
# Session of 2026-11-29 (third): images of the base binary (/tmp/candela_base_s, unpacked from
# .carry/z/base.tar.xz), the occupancy mask (.carry/b) and its per-brick word cache (.carry/m),
# vct at 1280x720, 8 spp, byte-compared.
. bench/gpu_env.sh > /dev/null
tar xJf .carry/z/base.tar.xz -C /tmp
for s in cornell textured_mesh lights shade mirror_glass; do
  /tmp/candela_base_s render scenes/$s.json --integrator vct --width 1280 --height 720 --spp 8 -o /tmp/${s}_base.exr > /dev/null 2>&1
  for v in b m; do
    .carry/$v/candela render scenes/$s.json --integrator vct --width 1280 --height 720 --spp 8 -o /tmp/${s}_$v.exr > /dev/null 2>&1
    cmp -s /tmp/${s}_base.exr /tmp/${s}_$v.exr && echo "IDENTICAL $s base $v" || echo "DIFFERENT $s base $v"
  done
done
