// vct stage 3 (dense storage): one anisotropic mip level m ≥ 1 of the dense grid, one thread per
// cell of level m, from the eight cells of level m − 1 (at level 0, each voxel's side facing the direction).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "vct/common.glsl"
#include "vct/aniso.glsl"

layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

void main() {
    uint m = VP_LEVEL;
    uint n = vct_res() >> m, nc = n * 2u;
    uint cell = LINEAR_GID;
    if (cell >= n * n * n) return;
    uvec3 c = uvec3(cell % n, (cell / n) % n, cell / (n * n));
    vec4 ch[8][6];
    for (uint o = 0u; o < 8u; ++o) {
        uvec3 cc = 2u * c + octant_bits(o);
        uint lin = cc.x + nc * (cc.y + nc * cc.z);
        if (m == 1u) {
            for (uint d = 0u; d < 6u; ++d) ch[o][d] = level0_value(lin, d);
        } else {
            uint at = (P.mip_offset[m - 1u] + lin) * 6u;
            for (uint d = 0u; d < 6u; ++d) ch[o][d] = unpack_h4(mip[at + d]);
        }
    }
    vec4 outv[6];
    aniso_filter(ch, outv);
    uint at = (P.mip_offset[m] + cell) * 6u;
    for (uint d = 0u; d < 6u; ++d) mip[at + d] = pack_h4(outv[d]);
}
