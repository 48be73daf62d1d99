// Crassin et al. 2011's anisotropic pre-integration: the value a parent cell shows to a cone
// travelling along +x (−x, ±y, ±z) is the average over the four rows of its 2×2×2 children along
// that axis of the two children composited front to back (premultiplied: c = c_f + (1 − α_f)·c_b,
// α = α_f + (1 − α_f)·α_b), the front one being the child the cone enters first.
#ifndef VCT_ANISO_GLSL
#define VCT_ANISO_GLSL

// ch[o][dir]: child o (octant bits x | y<<1 | z<<2) as seen along direction dir
// (0 +x, 1 −x, 2 +y, 3 −y, 4 +z, 5 −z). out[dir]: the parent.
void aniso_filter(in vec4 ch[8][6], out vec4 o[6]) {
    for (uint dir = 0u; dir < 6u; ++dir) {
        uint axis = dir >> 1u;
        bool positive = (dir & 1u) == 0u;
        uint abit = 1u << axis;
        vec4 sum = vec4(0.0);
        for (uint c = 0u; c < 8u; ++c) {
            if ((c & abit) != 0u) continue; // c: the low child of a row
            uint hi = c | abit;
            vec4 f = positive ? ch[c][dir] : ch[hi][dir];
            vec4 b = positive ? ch[hi][dir] : ch[c][dir];
            sum += f + (1.0 - clamp(f.a, 0.0, 1.0)) * b;
        }
        o[dir] = 0.25 * sum;
    }
}

#endif
