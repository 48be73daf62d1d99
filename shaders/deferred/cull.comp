// `deferred`, stage 2: tiled light culling (after Harada et al. 2012 "Forward+" and Olsson &
// Assarsson 2011 "Tiled Shading", with 3D tile bounds instead of a frustum and depth range).
// One 16×16 workgroup per screen tile and sample of the batch (z: the slice): its threads reconstruct their pixels' surface points
// from the G-buffer (camera ray + depth) and reduce them to two axis-aligned bounding boxes —
// the points nearer than the middle of the tile's depth range and the farther ones (splitting
// at the middle depth, like the depth-range splits of 2.5D culling, keeps a foreground object
// and the background behind it from making one huge box) — then test every light against
// them in chunks of 256 — its influence sphere against each box, and a spot's (or area
// emitter's) cone against the box's bounding sphere — and append the survivors, in light
// order, to the tile's list. The boxes are the tile's depth bounds made exact in 3D: they are
// conservative for any camera (also the thin lens, whose rays do not share an origin). A tile whose list would exceed `tile_capacity` is marked TILE_OVERFLOW and
// shaded against every light, so nothing is ever dropped for lack of space.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "deferred/common.glsl"

layout(local_size_x = TILE, local_size_y = TILE, local_size_z = 1) in;

shared uint s_lo[6];   // box b: components 3b .. 3b+2 (ordered-uint floats)
shared uint s_hi[6];
shared uint s_any[2];
shared uint s_tmin;
shared uint s_tmax;
shared uint s_scan[TILE * TILE];
shared uint s_count;
shared bool s_overflow;

// Squared distance from c to the box [lo, hi].
float dist2_box(vec3 c, vec3 lo, vec3 hi) {
    vec3 d = max(max(lo - c, c - hi), vec3(0.0));
    return dot(d, d);
}

// Whether light l may reach some point of the box [lo, hi] (conservative).
bool light_touches_box(DLight l, vec3 lo, vec3 hi) {
    vec3 c = l.pos_radius.xyz;
    float r = l.pos_radius.w;
    // Influence sphere against the box.
    if (dist2_box(c, lo, hi) > r * r) return false;
    uint kind = dl_kind(l);
    if (kind == DL_SPOT || kind == DL_COSINE) {
        // Cone (apex c, axis, half-angle θ) against the box's bounding sphere (centre bc,
        // radius br): outside when the sphere lies wholly beyond the cone's side or behind its
        // apex plane (Wronski 2016, "Cull that cone!").
        float cos_t = l.axis.w;
        if (cos_t > 0.0 || kind == DL_COSINE) {
            float sin_t = safe_sqrt(1.0 - cos_t * cos_t);
            vec3 bc = 0.5 * (lo + hi);
            float br = 0.5 * length(hi - lo);
            vec3 v = bc - c;
            float v_len2 = dot(v, v);
            float v1 = dot(v, l.axis.xyz);
            float closest = cos_t * safe_sqrt(v_len2 - v1 * v1) - v1 * sin_t;
            if (closest > br) return false;
            if (v1 < -br) return false;
        }
    }
    return true;
}

void main() {
    uint lid = gl_LocalInvocationIndex;
    uvec2 tile = gl_WorkGroupID.xy;
    uint slice = gl_WorkGroupID.z;
    uint tile_index = tile_slot(slice, tile.y * dp.tiles_x + tile.x);
    if (lid == 0u) {
        for (int i = 0; i < 6; ++i) { s_lo[i] = 0xffffffffu; s_hi[i] = 0u; }
        s_any[0] = 0u;
        s_any[1] = 0u;
        s_tmin = 0xffffffffu;
        s_tmax = 0u;
        s_count = 0u;
        s_overflow = false;
    }
    barrier();
    // Step 1: this pixel's surface point, from the camera ray and the stored depth, and the
    // tile's depth range.
    uvec2 px = gl_GlobalInvocationID.xy;
    bool hit = false;
    vec3 p = vec3(0.0);
    float t = 0.0;
    if (px.x < g.film.x && px.y < g.film.y) {
        uvec4 w = gbuf[gbuf_index(slice, px.y * g.film.x + px.x)];
        if (w.z != NONE) {
            Rng rng;
            Ray ray = sample_camera_ray(px, pc.sample_base + slice, rng);
            t = uintBitsToFloat(w.y);
            p = ray.o + t * ray.d;
            hit = true;
            atomicMin(s_tmin, float_order(t));
            atomicMax(s_tmax, float_order(t));
        }
    }
    barrier();
    // Step 2: the near and far boxes (split at the middle depth; ordered-uint atomics), widened
    // by the position's rounding error so they surely contain what the shade stage rebuilds.
    if (hit) {
        float mid = 0.5 * (float_unorder(s_tmin) + float_unorder(s_tmax));
        uint b = t <= mid ? 0u : 1u;
        vec3 e = 1e-5 * (abs(p) + vec3(1e-30));
        for (uint i = 0u; i < 3u; ++i) {
            atomicMin(s_lo[3u * b + i], float_order(p[i] - e[i]));
            atomicMax(s_hi[3u * b + i], float_order(p[i] + e[i]));
        }
        atomicOr(s_any[b], 1u);
    }
    barrier();
    if (s_any[0] == 0u && s_any[1] == 0u) {
        if (lid == 0u) tile_counts[tile_index] = 0u;
        return;
    }
    bool any0 = s_any[0] != 0u, any1 = s_any[1] != 0u;
    vec3 lo0 = vec3(float_unorder(s_lo[0]), float_unorder(s_lo[1]), float_unorder(s_lo[2]));
    vec3 hi0 = vec3(float_unorder(s_hi[0]), float_unorder(s_hi[1]), float_unorder(s_hi[2]));
    vec3 lo1 = vec3(float_unorder(s_lo[3]), float_unorder(s_lo[4]), float_unorder(s_lo[5]));
    vec3 hi1 = vec3(float_unorder(s_hi[3]), float_unorder(s_hi[4]), float_unorder(s_hi[5]));
    uint base = tile_index * dp.tile_capacity;
    // Step 3: every light against the boxes, 256 at a time; survivors are compacted in light
    // order by a prefix sum (Hillis–Steele in shared memory), so the list is deterministic.
    for (uint chunk = 0u; chunk < dp.n_cull; chunk += TILE * TILE) {
        uint li = chunk + lid;
        bool touches = false;
        if (li < dp.n_cull) {
            DLight l = dlights[li];
            touches = (any0 && light_touches_box(l, lo0, hi0)) || (any1 && light_touches_box(l, lo1, hi1));
        }
        uint keep = touches ? 1u : 0u;
        s_scan[lid] = keep;
        barrier();
        for (uint off = 1u; off < TILE * TILE; off <<= 1) {
            uint add = lid >= off ? s_scan[lid - off] : 0u;
            barrier();
            s_scan[lid] += add;
            barrier();
        }
        uint total = s_scan[TILE * TILE - 1u];
        uint at = s_count + s_scan[lid] - keep;
        if (keep == 1u && at < dp.tile_capacity) tile_lights[base + at] = li;
        barrier();
        if (lid == 0u) {
            s_count += total;
            if (s_count > dp.tile_capacity) s_overflow = true;
        }
        barrier();
        if (s_overflow) break;
    }
    if (lid == 0u) tile_counts[tile_index] = s_overflow ? TILE_OVERFLOW : s_count;
}
