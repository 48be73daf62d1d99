// The light BVH sampler (render.light_sampler "bvh"; renderer/src/compile/light_bvh.rs builds the
// tree and is the reference this mirrors): from a shading point p, descend the tree choosing
// each child with probability ∝ its importance, an upper bound of the light it can send to p
// (power · cosine of the smallest angle between its emission cone and p / distance² · the
// receiver's |cosine| bound at p's shading normal n; Conty Estevez & Kulla 2018, pbrt-v4's
// BVHLightSampler; n = 0: no receiver term, e.g. for voxels without a normal). Infinite
// lights are picked first, uniformly, with probability g.env_params.w (their share of the power).
// The probability of a
// given light is found again from its bit trail (light_bvh_pmf), with the same arithmetic, so
// NEE and the MIS weights of BSDF samples that hit a light use the same value.
// Needs common/bindings.glsl; g.counts.z = tree nodes, g.counts.w = infinite lights after them.
#ifndef COMMON_LIGHT_BVH_GLSL
#define COMMON_LIGHT_BVH_GLSL

layout(set = 0, binding = B_LIGHT_BVH, scalar) readonly buffer LightBvh { GpuLightNode light_nodes[]; };

const float LBVH_ONE_MINUS_EPS = 0.99999994;
// d² is at least (diagonal / 8)² (light_bvh.rs MIN_D2_SCALE).
const float LBVH_MIN_D2_SCALE = 1.0 / 64.0;

// cos(max(0, a − b)) and sin(max(0, a − b)) from the sines and cosines of a and b.
float lbvh_cos_sub(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 1.0 : cos_a * cos_b + sin_a * sin_b;
}
float lbvh_sin_sub(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 0.0 : sin_a * cos_b - cos_a * sin_b;
}

// The importance of node n at p with shading normal nrm (LightBounds::importance).
float light_node_importance(GpuLightNode n, vec3 p, vec3 nrm) {
    // Step 1: the distance to the centre, at least an eighth of the diagonal.
    vec3 bmin = n.min_phi.xyz, bmax = n.max_cos_o.xyz;
    vec3 pc = 0.5 * (bmin + bmax);
    vec3 diag = bmax - bmin;
    vec3 d = p - pc;
    float dd = dot(d, d);
    float d2 = max(max(dd, LBVH_MIN_D2_SCALE * dot(diag, diag)), 1e-12);
    // Step 2: the angle between the cone's axis and p, less the cone's spread and the angle
    // the box's bounding sphere subtends from p.
    float cos_w = dd > 0.0 ? dot(n.w_cos_e.xyz, d * inversesqrt(dd)) : 1.0;
    float sin_w = sqrt(max(1.0 - cos_w * cos_w, 0.0));
    float r2 = 0.25 * dot(diag, diag);
    float cos_b = dd < r2 ? -1.0 : sqrt(max(1.0 - r2 / dd, 0.0));
    float sin_b = sqrt(max(1.0 - cos_b * cos_b, 0.0));
    float cos_o = n.max_cos_o.w;
    float sin_o = sqrt(max(1.0 - cos_o * cos_o, 0.0));
    float cos_x = lbvh_cos_sub(sin_w, cos_w, sin_o, cos_o);
    float sin_x = lbvh_sin_sub(sin_w, cos_w, sin_o, cos_o);
    float cos_p = lbvh_cos_sub(sin_x, cos_x, sin_b, cos_b);
    // Step 3: nothing past the emission's spread.
    if (cos_p <= n.w_cos_e.w) return 0.0;
    // Step 4: the receiver's |cosine| at its smallest angle to the bounding sphere (either side:
    // the BSDF may transmit).
    float cos_r = 1.0;
    if (dd > 0.0 && dot(nrm, nrm) > 0.0) {
        float cos_i = abs(dot(nrm, d)) * inversesqrt(dd);
        float sin_i = sqrt(max(1.0 - cos_i * cos_i, 0.0));
        cos_r = lbvh_cos_sub(sin_i, cos_i, sin_b, cos_b);
    }
    return max(n.min_phi.w * cos_p * cos_r / d2, 0.0);
}

// The receiver's normal as the importance takes it: unit, or 0 (none).
vec3 light_bvh_unit(vec3 nrm) {
    float n2 = dot(nrm, nrm);
    return n2 > 0.0 ? nrm * inversesqrt(n2) : vec3(0.0);
}

float light_bvh_p_infinite() {
    return g.counts.w == 0u ? 0.0 : g.env_params.w;
}

// The probability of the first child of inner node i from p; false when neither can reach p.
bool light_bvh_p_first(uint i, GpuLightNode node, vec3 p, vec3 nrm, out float p0) {
    float c0 = light_node_importance(light_nodes[i + 1u], p, nrm);
    float c1 = light_node_importance(light_nodes[node.index], p, nrm);
    p0 = c0 / (c0 + c1);
    return c0 + c1 > 0.0;
}

// Picks a light from p (shading normal nrm) with u ∈ [0, 1): its index and probability; false
// when none can reach p.
bool light_bvh_pick(vec3 p, vec3 nrm, float u, out uint li, out float pmf) {
    li = 0u;
    pmf = 0.0;
    nrm = light_bvh_unit(nrm);
    // Step 1: an infinite light, or the tree.
    uint n_tree = g.counts.z, n_inf = g.counts.w;
    float p_inf = light_bvh_p_infinite();
    if (u < p_inf) {
        uint k = min(uint(u / p_inf * float(n_inf)), n_inf - 1u);
        li = light_nodes[n_tree + k].index;
        pmf = p_inf / float(n_inf);
        return true;
    }
    if (n_tree == 0u) return false;
    u = min((u - p_inf) / (1.0 - p_inf), LBVH_ONE_MINUS_EPS);
    // Step 2: down the tree, each child ∝ its importance, u rescaled at each choice.
    pmf = 1.0 - p_inf;
    uint i = 0u;
    for (uint depth = 0u; depth < 32u; ++depth) {
        GpuLightNode node = light_nodes[i];
        if ((node.flags & 1u) != 0u) {
            li = node.index;
            return light_node_importance(node, p, nrm) > 0.0;
        }
        float p0;
        if (!light_bvh_p_first(i, node, p, nrm, p0)) return false;
        if (u < p0) {
            u = min(u / p0, LBVH_ONE_MINUS_EPS);
            pmf *= p0;
            i = i + 1u;
        } else {
            u = min((u - p0) / (1.0 - p0), LBVH_ONE_MINUS_EPS);
            pmf *= 1.0 - p0;
            i = node.index;
        }
    }
    return false;
}

// The probability that light_bvh_pick from p (shading normal nrm) picks light li (along its
// bit trail).
float light_bvh_pmf(uint li, vec3 p, vec3 nrm) {
    GpuLight l = lights[li];
    nrm = light_bvh_unit(nrm);
    float p_inf = light_bvh_p_infinite();
    if (l.kind == LIGHT_DIRECTIONAL || light_is_env(l.kind)) {
        return g.counts.w == 0u ? 0.0 : p_inf / float(g.counts.w);
    }
    if (g.counts.z == 0u) return 0.0;
    float pmf = 1.0 - p_inf;
    uint i = 0u;
    for (uint depth = 0u; depth < 32u; ++depth) {
        GpuLightNode node = light_nodes[i];
        if ((node.flags & 1u) != 0u) {
            return node.index == li && light_node_importance(node, p, nrm) > 0.0 ? pmf : 0.0;
        }
        float p0;
        if (!light_bvh_p_first(i, node, p, nrm, p0)) return 0.0;
        if (((l.bvh_trail >> depth) & 1u) == 0u) {
            pmf *= p0;
            i = i + 1u;
        } else {
            pmf *= 1.0 - p0;
            i = node.index;
        }
    }
    return 0.0;
}

#endif
