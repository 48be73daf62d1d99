// Layout check: reads one instance of every GPU struct (types.glsl) and writes its fields, in
// declaration order, as 32-bit words. The host fills each struct with the words 1, 2, 3, ... in
// its own (Rust) layout, so the output is 1, 2, 3, ... exactly when both layouts agree.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "common/types.glsl"

layout(local_size_x = 1) in;

layout(binding = 0, scalar) readonly buffer B0 { GpuGlobals v_globals; };
layout(binding = 1, scalar) readonly buffer B1 { GpuBvhNode v_node; };
layout(binding = 2, scalar) readonly buffer B2 { GpuPrim v_prim; };
layout(binding = 3, scalar) readonly buffer B3 { GpuTriShading v_shading; };
layout(binding = 4, scalar) readonly buffer B4 { GpuMaterial v_material; };
layout(binding = 5, scalar) readonly buffer B5 { GpuTexture v_texture; };
layout(binding = 6, scalar) readonly buffer B6 { GpuLight v_light; };
layout(binding = 7, scalar) readonly buffer B7 { GpuAlias v_alias; };
layout(binding = 8, scalar) readonly buffer B8 { GpuStats v_stats; };
layout(binding = 9, scalar) buffer Out { uint o[]; };
layout(binding = 10, scalar) readonly buffer B10 { GpuInstance v_instance; };

uint k = 0u;
void pu(uint x) { o[k++] = x; }
void pf(float x) { o[k++] = floatBitsToUint(x); }
void pi(int x) { o[k++] = uint(x); }
void p3(vec3 v) { pf(v.x); pf(v.y); pf(v.z); }
void p4(vec4 v) { pf(v.x); pf(v.y); pf(v.z); pf(v.w); }
void u4(uvec4 v) { pu(v.x); pu(v.y); pu(v.z); pu(v.w); }

void main() {
    // Each struct starts at a fixed word offset (multiples of 64; the globals take two slots) so
    // one mismatch cannot hide another.
    k = 0u;
    p4(v_globals.cam_forward); p4(v_globals.cam_right); p4(v_globals.cam_up); p4(v_globals.lens);
    u4(v_globals.film); p4(v_globals.filter_params); p4(v_globals.scene_sphere); u4(v_globals.env);
    p4(v_globals.env_params); u4(v_globals.counts); u4(v_globals.instances); u4(v_globals.scene_flags);
    for (int i = 0; i < 32; ++i) pf(v_globals.filter_c[i]);
    for (int i = 0; i < 32; ++i) pu(v_globals.filter_alias[i]);
    k = 128u;
    p3(v_node.l_min); pu(v_node.left); p3(v_node.l_max); pu(v_node.right);
    p3(v_node.r_min); pu(v_node.l_count); p3(v_node.r_max); pu(v_node.r_count);
    k = 192u;
    p4(v_prim.a); p4(v_prim.b); p4(v_prim.c);
    k = 256u;
    p4(v_shading.n0); p4(v_shading.n1); p4(v_shading.n2); p4(v_shading.uv_v);
    k = 320u;
    u4(v_material.header); p4(v_material.emission);
    for (int i = 0; i < 3; ++i) p4(v_material.colors[i]);
    for (int i = 0; i < 12; ++i) pf(v_material.scalars[i]);
    for (int i = 0; i < 12; ++i) pu(v_material.scalar_tex[i]);
    k = 384u;
    pu(v_texture.offset); pu(v_texture.width); pu(v_texture.height); pu(v_texture.flags);
    pf(v_texture.scale.x); pf(v_texture.scale.y); pf(v_texture.pad.x); pf(v_texture.pad.y);
    k = 448u;
    pu(v_light.kind); pu(v_light.prim); pf(v_light.pick_pdf); pu(v_light.bvh_trail);
    p4(v_light.p0); p4(v_light.p1); p4(v_light.p2); p4(v_light.radiance);
    k = 512u;
    pf(v_alias.prob); pu(v_alias.alias);
    k = 576u;
    pu(v_stats.dropped_samples); pu(v_stats.rays_lo); pu(v_stats.rays_hi); pu(v_stats.pad);
    k = 640u;
    pu(pc.seed_lo); pu(pc.seed_hi); pu(pc.sample_base); pu(pc.spp);
    pi(pc.max_depth); pi(pc.rr_depth); pu(pc.flags); pu(pc.dispatch);
    k = 704u;
    for (int i = 0; i < 3; ++i) p4(v_instance.world_to_object[i]);
    for (int i = 0; i < 3; ++i) p4(v_instance.object_to_world[i]);
    pu(v_instance.root); pu(v_instance.material); pu(v_instance.flags); pu(v_instance.pad);
}
