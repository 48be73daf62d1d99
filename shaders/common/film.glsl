// The film end of every kernel's sample loop, written once: a sample's radiance joins the
// pixel's accumulation (Σr, Σg, Σb, samples kept) unless it is NaN or Inf, in which case it is
// dropped and counted; the pass's counters (rays, dropped samples) are added once per invocation
// (or workgroup). Samples of odd index are also summed into `film_odd`, which the kernel adds to
// ACCUM_ODD with film_odd_store when it stores the pixel: the even and odd halves are two
// independent estimates, whose difference estimates the image's variance without a reference
// (renderer/src/metrics/estimate.rs). Needs common/bindings.glsl (ACCUM, ACCUM_ODD, STATS) and
// the push constants.
#ifndef COMMON_FILM_GLSL
#define COMMON_FILM_GLSL

bool is_finite(vec3 v) { return !any(isnan(v)) && !any(isinf(v)); }

// This invocation's odd-indexed samples not yet added to ACCUM_ODD (Σr, Σg, Σb, samples kept).
vec4 film_odd = vec4(0.0);

// Adds sample `sample_index`'s radiance L to the pixel accumulation `acc`, or counts it in
// `dropped`. Test hook (PUSH_FLAG_INJECT_NAN): every 7th sample index is poisoned with NaN first,
// so tests can check that such samples never reach the film.
void film_add(inout vec4 acc, vec3 L, uint sample_index, inout uint dropped) {
    if ((pc.flags & PUSH_FLAG_INJECT_NAN) != 0u && sample_index % 7u == 3u) {
        L = vec3(uintBitsToFloat(0x7fc00000u));
    }
    if (is_finite(L)) {
        acc += vec4(L, 1.0);
        if ((sample_index & 1u) == 1u) film_odd += vec4(L, 1.0);
    } else {
        dropped += 1u;
    }
}

// Adds the odd-indexed samples summed since the last call to the pixel's odd half (the thread
// that stores the pixel's ACCUM entry calls it, so no other thread writes the entry).
void film_odd_store(uint pixel) {
    if (film_odd.w > 0.0) accum_odd[pixel] += film_odd;
    film_odd = vec4(0.0);
}

// Adds an invocation's (or a workgroup's) counters to the pass's: dropped samples, and rays as a
// 64-bit count in two words (carry into the high word when the low word wraps). With COUNT_STEPS
// (bindings.glsl) the "rays" are the invocation's node fetches or primitive tests.
void film_count(uint rays, uint dropped) {
#ifdef COUNT_STEPS
    rays = COUNT_STEPS == 1 ? count_nodes : count_prims;
#endif
#ifdef COUNT_CLOCK
    rays = COUNT_CLOCK == 3 ? clock2x32ARB().x - count_clock_start : count_clock;
#endif
    if (dropped > 0u) atomicAdd(stats.dropped_samples, dropped);
    if (rays > 0u) {
        uint before = atomicAdd(stats.rays_lo, rays);
        if (before + rays < before) atomicAdd(stats.rays_hi, 1u);
    }
}

#endif
