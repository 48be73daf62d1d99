// vct option `bounces: 2`: the second bounce by re-injection. Mode 0: every occupied voxel
// gathers the first bounce's filtered radiance with the diffuse cones around its normal (and
// around the opposite for two-sided surfaces: the back side) and keeps L₂ = albedo/π · E per side; mode 1 adds L₂ to the
// injected radiance, which is then filtered again.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "vct/common.glsl"
#include "vct/cone.glsl"

layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

void main() {
    uint slot = LINEAR_GID;
    if (slot >= VP_COUNT) return;
    if (VP_MODE == 1u) {
        uvec4 a = rad[slot], b = bounce[slot];
        vec4 f = unpack_h4(a.xy), k = unpack_h4(a.zw);
        rad[slot] = uvec4(pack_h4(vec4(f.rgb + unpack_h4(b.xy).rgb, f.a)), pack_h4(vec4(k.rgb + unpack_h4(b.zw).rgb, k.a)));
        return;
    }
    Voxel vx = load_voxel(slot);
    if (vx.opacity <= 0.0 || dot(vx.n, vx.n) == 0.0) { bounce[slot] = uvec4(0u); return; }
    uint n = VCT_CONES;
    float tan_half = P.cone.x;
    vec3 E[2] = vec3[2](vec3(0.0), vec3(0.0));
    for (int side = 0; side < 2; ++side) {
        if (side == 1 && !vx.two_sided) break;
        vec3 nn = side == 0 ? vx.n : -vx.n;
        vec3 t, b;
        make_frame(nn, t, b);
        vec3 origin = vx.p + nn * (CONE_OFFSET * P.grid.w);
        vec3 Es = vec3(0.0);
        for (uint i = 0u; i < n; ++i) {
            vec3 d = from_local(diffuse_cone_dir(i, n, 0.0), t, b, nn);
            Es += cone_trace(origin, d, tan_half, 1.0, 1e9).rgb;
        }
        E[side] = Es * (PI / float(n));
    }
    vec3 L = min(vx.albedo * INV_PI * E[0] * vx.opacity, vec3(6e4));
    vec3 Lb = min(vx.albedo * INV_PI * E[1] * vx.opacity, vec3(6e4));
    bounce[slot] = uvec4(pack_h4(vec4(L, 0.0)), pack_h4(vec4(Lb, 0.0)));
}
