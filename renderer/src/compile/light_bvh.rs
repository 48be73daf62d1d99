//! A spatially aware light sampler: a BVH over the scene's bounded lights (emissive triangles and
//! spheres, point and spot lights), each node bounding its lights' positions, power and emission
//! directions (Conty Estevez & Kulla 2018, "Importance Sampling of Many Lights with Adaptive
//! Tree Splitting"; pbrt-v4's `BVHLightSampler`). From a shading point p a light is picked by
//! descending the tree, choosing each child with probability ∝ its importance, an upper bound of
//! the light it can send towards p: power · (cosine of the smallest angle between its emission
//! cone and p) / distance² · (the receiver's |cosine|: at p's shading normal n, towards the
//! nearest direction of the node's bounding sphere; either side, as a BSDF may transmit). The
//! pick's probability is the product of the choices; the GPU finds
//! it again for MIS from the light's path in the tree (its "bit trail"). Infinite lights
//! (directional, environment) are picked first, with the share of the total power they have in
//! the power sampler, uniformly among them. (pbrt-v4 picks them with probability
//! n_inf / (n_inf + 1): half the samples for one dim environment, which measured 1.7× the
//! power sampler's noise on tests/tests/light_sampler.rs's scene.)
//!
//! This module is the reference implementation (build, importance, sampling, pmf), mirrored in
//! shaders/common/light_bvh.glsl. Every pick and every MIS lookup passes the same (p, n): the
//! shading point and its shading normal; n = 0 (no receiver term) where there is no surface
//! normal (e.g. vct's voxels).

use glam::DVec3;

use crate::layout::{light, GpuLight, GpuLightNode};

/// What bounds one light or a group: positions, power, and emission directions (a cone of
/// normals `w`/`cos_theta_o`, spread by `cos_theta_e`, the emission's angle past the normal).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightBounds {
    pub min: DVec3,
    pub max: DVec3,
    pub phi: f64,
    pub w: DVec3,
    pub cos_theta_o: f64,
    pub cos_theta_e: f64,
}

/// Most levels of the tree (bit trails are 32-bit; light_split.rs keeps every leaf within it).
pub const MAX_DEPTH: usize = 31;

/// The importance's distance² is at least this times the box's squared diagonal: (diagonal /
/// 8)². It matters where p is near or inside a node, whose lights are then anywhere from next to
/// p to the far side of the box. The earlier (diagonal / 2)² undersampled the lights next to p:
/// on the 256-light scene (bench/RESULTS.md) nee's relMSE at 100 ms was 3.8× that of
/// (diagonal / 8)², 1.9× on 10,000 and 1.7× on 100,000 emissive triangles; scales from 1/16 to
/// 1/10,000 were within 10% of each other. (pbrt-v4 clamps d² by half the diagonal's length, not
/// its square: close on that scene, but it depends on the scene's unit.)
pub const MIN_D2_SCALE: f64 = 1.0 / 64.0;

/// Node flag: a leaf (its `index` is a light).
pub const NODE_LEAF: u32 = 1;

impl LightBounds {
    /// Bounds of lights in the box [min, max] that shine in every direction, of power phi.
    pub(crate) fn all_directions(min: DVec3, max: DVec3, phi: f64) -> LightBounds {
        LightBounds {
            min,
            max,
            phi,
            w: DVec3::Z,
            cos_theta_o: -1.0,
            cos_theta_e: 0.0,
        }
    }

    /// The bounds of light `l` (camera-relative) of power `phi`; None for infinite lights and
    /// lights of no power.
    pub fn of(l: &GpuLight, phi: f64) -> Option<LightBounds> {
        if !(phi > 0.0 && phi.is_finite()) {
            return None;
        }
        let p = |v: [f32; 4]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
        let all_directions = |min: DVec3, max: DVec3| LightBounds::all_directions(min, max, phi);
        match l.kind {
            light::TRIANGLE => {
                let (a, b, c) = (p(l.p0), p(l.p1), p(l.p2));
                let n = (b - a).cross(c - a);
                if !(n.length() > 0.0) {
                    return None;
                }
                Some(LightBounds {
                    min: a.min(b).min(c),
                    max: a.max(b).max(c),
                    phi,
                    w: n.normalize(),
                    cos_theta_o: 1.0,
                    cos_theta_e: 0.0,
                })
            }
            light::SPHERE => {
                let r = DVec3::splat(l.p0[3] as f64);
                Some(all_directions(p(l.p0) - r, p(l.p0) + r))
            }
            light::POINT => Some(all_directions(p(l.p0), p(l.p0))),
            light::SPOT => {
                // pbrt: the normal cone is the full-intensity beam, spread out to the cutoff.
                let (cos_cutoff, cos_beam) = (l.p2[0] as f64, l.p2[1] as f64);
                let theta_e = cos_cutoff.clamp(-1.0, 1.0).acos() - cos_beam.clamp(-1.0, 1.0).acos();
                Some(LightBounds {
                    min: p(l.p0),
                    max: p(l.p0),
                    phi,
                    w: p(l.p1).normalize(),
                    cos_theta_o: cos_beam,
                    cos_theta_e: theta_e.max(0.0).cos(),
                })
            }
            _ => None,
        }
    }

    /// The union of two bounds (pbrt-v4 `Union(LightBounds, LightBounds)`).
    pub fn union(&self, o: &LightBounds) -> LightBounds {
        let (w, cos_theta_o) = cone_union(self.w, self.cos_theta_o, o.w, o.cos_theta_o);
        LightBounds {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
            phi: self.phi + o.phi,
            w,
            cos_theta_o,
            cos_theta_e: self.cos_theta_e.min(o.cos_theta_e),
        }
    }

    pub(crate) fn centroid(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }

    /// An upper bound of the light these bounds can send to point `p` with unit shading
    /// normal `n` (zero: no receiver term), pbrt-v4's `LightBounds::Importance`.
    pub fn importance(&self, p: DVec3, n: DVec3) -> f64 {
        // Step 1: the distance to the centre, at least an eighth of the diagonal.
        let pc = self.centroid();
        let d2 = p
            .distance_squared(pc)
            .max(MIN_D2_SCALE * (self.max - self.min).length_squared())
            .max(1e-12);
        // Step 2: the angle between the cone's axis and the direction to p, less the cone's
        // spread and the angle the box subtends from p.
        let wi = (p - pc).normalize_or_zero();
        let cos_w = if wi == DVec3::ZERO {
            1.0
        } else {
            self.w.dot(wi)
        };
        let sin_w = safe_sqrt(1.0 - cos_w * cos_w);
        let cos_b = bound_subtended_cos(self.min, self.max, p);
        let sin_b = safe_sqrt(1.0 - cos_b * cos_b);
        let sin_o = safe_sqrt(1.0 - self.cos_theta_o * self.cos_theta_o);
        let cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
        // Step 3: nothing past the emission's spread.
        if cos_p <= self.cos_theta_e {
            return 0.0;
        }
        // Step 4: the receiver's |cosine| at its smallest angle to the bounding sphere.
        let cos_r = if wi == DVec3::ZERO || n == DVec3::ZERO {
            1.0
        } else {
            let cos_i = n.dot(wi).abs();
            cos_sub_clamped(safe_sqrt(1.0 - cos_i * cos_i), cos_i, sin_b, cos_b)
        };
        (self.phi * cos_p * cos_r / d2).max(0.0)
    }
}

fn safe_sqrt(x: f64) -> f64 {
    x.max(0.0).sqrt()
}

/// cos(max(0, a − b)) from the sines and cosines of a and b.
fn cos_sub_clamped(sin_a: f64, cos_a: f64, sin_b: f64, cos_b: f64) -> f64 {
    if cos_a > cos_b {
        1.0
    } else {
        cos_a * cos_b + sin_a * sin_b
    }
}

/// sin(max(0, a − b)).
fn sin_sub_clamped(sin_a: f64, cos_a: f64, sin_b: f64, cos_b: f64) -> f64 {
    if cos_a > cos_b {
        0.0
    } else {
        sin_a * cos_b - cos_a * sin_b
    }
}

/// The cosine of the half-angle of the cone from `p` that holds the box's bounding sphere (−1
/// when p is inside the sphere).
fn bound_subtended_cos(min: DVec3, max: DVec3, p: DVec3) -> f64 {
    let c = 0.5 * (min + max);
    let r2 = 0.25 * (max - min).length_squared();
    let d2 = p.distance_squared(c);
    if d2 < r2 {
        return -1.0;
    }
    safe_sqrt(1.0 - r2 / d2)
}

/// The smallest cone holding two cones (axis, cosine of the half-angle); pbrt-v4
/// `DirectionCone::Union`.
fn cone_union(wa: DVec3, cos_a: f64, wb: DVec3, cos_b: f64) -> (DVec3, f64) {
    if cos_a <= -1.0 || cos_b <= -1.0 {
        return (wa, -1.0);
    }
    let theta_a = cos_a.clamp(-1.0, 1.0).acos();
    let theta_b = cos_b.clamp(-1.0, 1.0).acos();
    let theta_d = wa.dot(wb).clamp(-1.0, 1.0).acos();
    if (theta_d + theta_b).min(std::f64::consts::PI) <= theta_a {
        return (wa, cos_a);
    }
    if (theta_d + theta_a).min(std::f64::consts::PI) <= theta_b {
        return (wb, cos_b);
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    if theta_o >= std::f64::consts::PI {
        return (wa, -1.0);
    }
    let theta_r = theta_o - theta_a;
    let wr = wa.cross(wb);
    if wr.length_squared() == 0.0 {
        return (wa, -1.0);
    }
    let w = glam::DQuat::from_axis_angle(wr.normalize(), theta_r) * wa;
    (w.normalize(), theta_o.cos())
}

/// The built tree: nodes in depth-first order (an inner node's first child follows it), each
/// bounded light's bit trail (bit k: took the second child at depth k), and the infinite lights.
#[derive(Debug, Clone, Default)]
pub struct LightBvh {
    pub nodes: Vec<Node>,
    /// Per light: Some((leaf node, bit trail)) for bounded lights in the tree.
    pub trails: Vec<Option<(u32, u32)>>,
    /// Indices of the infinite lights.
    pub infinite: Vec<u32>,
    /// The probability of picking an infinite light (their share of the total power).
    pub p_infinite: f64,
}

/// One node: its bounds and either its second child (inner) or its light (leaf).
#[derive(Debug, Clone, Copy)]
pub struct Node {
    pub bounds: LightBounds,
    pub leaf: bool,
    /// Inner: the second child's index; leaf: the light's.
    pub index: u32,
}

impl LightBvh {
    /// Builds the tree over `lights` with their powers (`LightBuilder`'s), split by the surface
    /// area orientation heuristic (light_split.rs).
    pub fn build(lights: &[GpuLight], power: &[f64]) -> LightBvh {
        let mut bvh = LightBvh {
            trails: vec![None; lights.len()],
            ..Default::default()
        };
        let mut bounded = Vec::new();
        let (mut p_inf, mut p_tree) = (0.0, 0.0);
        for (i, (l, &phi)) in lights.iter().zip(power).enumerate() {
            match LightBounds::of(l, phi) {
                Some(b) => {
                    bounded.push((i as u32, b));
                    p_tree += phi;
                }
                None if matches!(
                    l.kind,
                    light::DIRECTIONAL | light::ENV_CONSTANT | light::ENV_MAP
                ) =>
                {
                    bvh.infinite.push(i as u32);
                    p_inf += if phi.is_finite() { phi.max(0.0) } else { 0.0 };
                }
                None => {} // no power: never picked
            }
        }
        bvh.p_infinite = match (bvh.infinite.is_empty(), bounded.is_empty()) {
            (true, _) => 0.0,
            (false, true) => 1.0,
            // Infinite lights of no power are still picked a little (they may be all there is
            // to see in some direction).
            (false, false) => (p_inf / (p_inf + p_tree)).clamp(0.01, 0.99),
        };
        if !bounded.is_empty() {
            bvh.build_node(&mut bounded, 0, 0);
        }
        bvh
    }

    fn build_node(
        &mut self,
        items: &mut [(u32, LightBounds)],
        depth: usize,
        trail: u32,
    ) -> LightBounds {
        let at = self.nodes.len();
        if items.len() == 1 || depth >= MAX_DEPTH {
            // (At the depth limit, which the split reaches only past 2³¹ lights, the remaining
            // lights would be lost; a Vec of that size cannot exist here.)
            let (li, b) = items[0];
            self.nodes.push(Node {
                bounds: b,
                leaf: true,
                index: li,
            });
            self.trails[li as usize] = Some((at as u32, trail));
            return b;
        }
        // Step 1: where to split (light_split.rs: SAOH, else the median).
        let mid = super::light_split::split(items, depth);
        // Step 2: the children (first right after this node), then this node's union.
        self.nodes.push(Node {
            bounds: items[0].1,
            leaf: false,
            index: 0,
        });
        let (left, right) = items.split_at_mut(mid);
        let a = self.build_node(left, depth + 1, trail);
        let second = self.nodes.len() as u32;
        let b = self.build_node(right, depth + 1, trail | (1 << depth));
        self.nodes[at].index = second;
        self.nodes[at].bounds = a.union(&b);
        self.nodes[at].bounds
    }

    /// The probability of picking an infinite light (each has this over their count).
    pub fn p_infinite(&self) -> f64 {
        self.p_infinite
    }

    /// The probability of choosing the first child of inner node `i` from `p` (None: neither
    /// child can reach p).
    fn p_first(&self, i: usize, p: DVec3, n: DVec3) -> Option<f64> {
        let c0 = self.nodes[i + 1].bounds.importance(p, n);
        let c1 = self.nodes[self.nodes[i].index as usize]
            .bounds
            .importance(p, n);
        (c0 + c1 > 0.0).then(|| c0 / (c0 + c1))
    }

    /// Picks a light from `p` (shading normal `n`, or zero) with `u` ∈ [0, 1): (light,
    /// probability); None when none can reach p.
    pub fn sample(&self, p: DVec3, n: DVec3, mut u: f64) -> Option<(u32, f64)> {
        let n = n.normalize_or_zero();
        // Step 1: an infinite light, or the tree.
        let p_inf = self.p_infinite();
        if u < p_inf {
            let n = self.infinite.len();
            let k = ((u / p_inf * n as f64) as usize).min(n - 1);
            return Some((self.infinite[k], p_inf / n as f64));
        }
        if self.nodes.is_empty() {
            return None;
        }
        u = ((u - p_inf) / (1.0 - p_inf)).min(1.0 - f64::EPSILON);
        // Step 2: down the tree, each child ∝ its importance, u rescaled at each choice.
        let mut pmf = 1.0 - p_inf;
        let mut i = 0usize;
        loop {
            let node = &self.nodes[i];
            if node.leaf {
                return (node.bounds.importance(p, n) > 0.0).then_some((node.index, pmf));
            }
            let p0 = self.p_first(i, p, n)?;
            if u < p0 {
                u = (u / p0).min(1.0 - f64::EPSILON);
                pmf *= p0;
                i += 1;
            } else {
                u = ((u - p0) / (1.0 - p0)).min(1.0 - f64::EPSILON);
                pmf *= 1.0 - p0;
                i = node.index as usize;
            }
        }
    }

    /// The probability that [`Self::sample`] from `p` (shading normal `n`) picks `light`
    /// (following its bit trail).
    pub fn pmf(&self, p: DVec3, n: DVec3, light: u32) -> f64 {
        let n = n.normalize_or_zero();
        let p_inf = self.p_infinite();
        if self.infinite.contains(&light) {
            return p_inf / self.infinite.len() as f64;
        }
        let Some(Some((_, trail))) = self.trails.get(light as usize) else {
            return 0.0;
        };
        let mut pmf = 1.0 - p_inf;
        let mut i = 0usize;
        let mut depth = 0;
        while !self.nodes[i].leaf {
            let Some(p0) = self.p_first(i, p, n) else {
                return 0.0;
            };
            if trail & (1 << depth) == 0 {
                pmf *= p0;
                i += 1;
            } else {
                pmf *= 1.0 - p0;
                i = self.nodes[i].index as usize;
            }
            depth += 1;
        }
        if self.nodes[i].bounds.importance(p, n) > 0.0 {
            pmf
        } else {
            0.0
        }
    }

    /// The GPU form: the tree's nodes, then one leaf-like entry per infinite light.
    pub fn gpu_nodes(&self) -> Vec<GpuLightNode> {
        let f = |v: DVec3, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
        let mut out: Vec<GpuLightNode> = self
            .nodes
            .iter()
            .map(|n| GpuLightNode {
                min_phi: f(n.bounds.min, n.bounds.phi),
                max_cos_o: f(n.bounds.max, n.bounds.cos_theta_o),
                w_cos_e: f(n.bounds.w, n.bounds.cos_theta_e),
                index: n.index,
                flags: if n.leaf { NODE_LEAF } else { 0 },
                pad: [0; 2],
            })
            .collect();
        out.extend(self.infinite.iter().map(|&i| GpuLightNode {
            index: i,
            flags: NODE_LEAF,
            ..Default::default()
        }));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compile::lights::LightBuilder;
    use glam::Vec3;

    /// A scene of many lights: small triangles facing various ways on a grid, spheres, a point,
    /// a spot and an environment.
    fn lights() -> (Vec<GpuLight>, Vec<f64>) {
        let mut b = LightBuilder::new();
        for i in 0..40 {
            let x = (i % 8) as f64 - 4.0;
            let z = (i / 8) as f64 * 1.5 - 3.0;
            let o = DVec3::new(x, 2.0 + 0.1 * (i % 3) as f64, z);
            // Faces down, up or sideways by i.
            let (e1, e2) = match i % 3 {
                0 => (DVec3::X * 0.3, DVec3::Z * 0.3),
                1 => (DVec3::Z * 0.3, DVec3::X * 0.3),
                _ => (DVec3::Y * 0.3, DVec3::Z * 0.3),
            };
            let radiance = Vec3::splat(1.0 + (i % 5) as f32);
            b.triangle(i, [o, o + e1, o + e2], radiance);
        }
        b.sphere(
            100,
            DVec3::new(0.0, 1.0, 0.0),
            0.25,
            false,
            Vec3::splat(3.0),
        );
        b.point(DVec3::new(2.0, 0.5, 1.0), Vec3::splat(5.0));
        b.spot(
            DVec3::new(-2.0, 3.0, 0.0),
            -DVec3::Y,
            Vec3::splat(20.0),
            30.0,
            20.0,
        );
        b.env_constant(Vec3::splat(0.1), 10.0);
        (b.lights, b.power)
    }

    /// Shading points and their normals (zero: no receiver term).
    fn points() -> Vec<(DVec3, DVec3)> {
        vec![
            (DVec3::new(0.0, 0.0, 0.0), DVec3::ZERO),
            (DVec3::new(0.0, 0.0, 0.0), DVec3::Y),
            (
                DVec3::new(3.5, 1.9, -2.5),
                DVec3::new(1.0, 2.0, -0.5).normalize(),
            ),
            (DVec3::new(-4.0, 2.05, 3.0), DVec3::X),
            (DVec3::new(0.1, 10.0, 0.2), DVec3::ZERO),
            (DVec3::new(0.1, 10.0, 0.2), -DVec3::Y),
            (DVec3::new(-2.0, 2.9, 0.0), DVec3::Z),
        ]
    }

    /// The probability that sampling from `p` ends without a light: at an inner node whose
    /// children both have importance 0, or at a leaf of importance 0 (its bounds are tighter
    /// than its ancestors'); such lights cannot light p.
    fn dead_end_mass(bvh: &LightBvh, p: DVec3, n: DVec3) -> f64 {
        fn walk(bvh: &LightBvh, i: usize, p: DVec3, n: DVec3, mass: f64) -> f64 {
            let node = &bvh.nodes[i];
            if node.leaf {
                return if node.bounds.importance(p, n) > 0.0 {
                    0.0
                } else {
                    mass
                };
            }
            match bvh.p_first(i, p, n) {
                None => mass,
                Some(p0) => {
                    walk(bvh, i + 1, p, n, mass * p0)
                        + walk(bvh, node.index as usize, p, n, mass * (1.0 - p0))
                }
            }
        }
        walk(bvh, 0, p, n, 1.0 - bvh.p_infinite())
    }

    #[test]
    fn pmf_sums_to_one_and_matches_the_sampled_probability() {
        let (lights, power) = lights();
        let bvh = LightBvh::build(&lights, &power);
        assert_eq!(bvh.infinite.len(), 1);
        assert!(bvh.trails.iter().filter(|t| t.is_some()).count() == lights.len() - 1);
        for (p, n) in points() {
            // Σ pmf over lights plus the mass of samples that end without a light is 1.
            let total: f64 = (0..lights.len() as u32).map(|l| bvh.pmf(p, n, l)).sum();
            let dead = dead_end_mass(&bvh, p, n);
            println!("{p}: Σ pmf {total:.6}, no light {dead:.6}");
            assert!(
                (total + dead - 1.0).abs() < 1e-9,
                "{p}: Σ pmf = {total}, dead {dead}"
            );
            // Every light that can send light to p (its own importance) can be picked.
            for (l, t) in bvh.trails.iter().enumerate() {
                if let Some((leaf, _)) = t {
                    if bvh.nodes[*leaf as usize].bounds.importance(p, n) > 0.0 && dead == 0.0 {
                        assert!(bvh.pmf(p, n, l as u32) > 0.0, "{p}: light {l}");
                    }
                }
            }
            for k in 0..200 {
                let u = (k as f64 + 0.5) / 200.0;
                if let Some((l, pmf)) = bvh.sample(p, n, u) {
                    assert!(
                        (pmf - bvh.pmf(p, n, l)).abs() < 1e-12 * pmf.max(1.0),
                        "{p} {l}"
                    );
                }
            }
        }
    }

    #[test]
    fn sampling_frequencies_match_the_pmf_chi_square() {
        let (lights, power) = lights();
        let bvh = LightBvh::build(&lights, &power);
        let n = 200_000usize;
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for (p, nrm) in points() {
            // counts[lights.len()]: samples that ended without a light.
            let mut counts = vec![0usize; lights.len() + 1];
            for _ in 0..n {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                match bvh.sample(p, nrm, u) {
                    Some((l, _)) => counts[l as usize] += 1,
                    None => counts[lights.len()] += 1,
                }
            }
            // Pearson's χ² over outcomes expected ≥ 5 times (the rest must be 0 or rare).
            let mut chi2 = 0.0;
            let mut dof = 0usize;
            for (l, &c) in counts.iter().enumerate() {
                let prob = if l < lights.len() {
                    bvh.pmf(p, nrm, l as u32)
                } else {
                    dead_end_mass(&bvh, p, nrm)
                };
                let e = prob * n as f64;
                if e >= 5.0 {
                    chi2 += (c as f64 - e).powi(2) / e;
                    dof += 1;
                } else {
                    assert!(
                        c as f64 <= e + 5.0 * e.sqrt() + 5.0,
                        "light {l}: {c} vs {e}"
                    );
                }
            }
            // 99.9% quantile of χ² with ~dof degrees of freedom: dof + 3.1·√(2 dof) + 10.
            let limit = dof as f64 + 3.1 * (2.0 * dof as f64).sqrt() + 10.0;
            assert!(
                chi2 < limit,
                "{p}: χ² {chi2:.1} over {dof} lights (limit {limit:.1})"
            );
        }
    }

    #[test]
    fn lights_facing_away_or_far_are_picked_less() {
        // Two equal triangles 1 above p: one faces p (down), one faces away (up): the one
        // facing away can send nothing to p and is never picked. A third, as strong, 10× as far,
        // facing p, is picked far less than the near one.
        let mut b = LightBuilder::new();
        let o = DVec3::new(0.0, 1.0, 0.0);
        b.triangle(0, [o, o + DVec3::X * 0.1, o + DVec3::Z * 0.1], Vec3::ONE); // normal −Y
        b.triangle(1, [o, o + DVec3::Z * 0.1, o + DVec3::X * 0.1], Vec3::ONE); // normal +Y
        let f = DVec3::new(0.0, 10.0, 0.0);
        b.triangle(2, [f, f + DVec3::X * 0.1, f + DVec3::Z * 0.1], Vec3::ONE);
        let bvh = LightBvh::build(&b.lights, &b.power);
        let p = DVec3::ZERO;
        for n in [DVec3::ZERO, DVec3::Y] {
            assert_eq!(bvh.pmf(p, n, 1), 0.0);
            assert!(
                bvh.pmf(p, n, 0) > 10.0 * bvh.pmf(p, n, 2),
                "{} {}",
                bvh.pmf(p, n, 0),
                bvh.pmf(p, n, 2)
            );
        }
    }

    #[test]
    fn lights_at_grazing_angles_to_the_receiver_are_picked_less() {
        // Two equal point lights as far from p: one straight above its normal, one nearly in
        // its tangent plane. Without a normal they are picked alike; with it, the grazing one
        // about as much less as its cosine (the point's sphere is tiny), on either side.
        let mut b = LightBuilder::new();
        b.point(DVec3::new(0.0, 4.0, 0.0), Vec3::ONE);
        b.point(DVec3::new((16.0f64 - 0.04).sqrt(), 0.2, 0.0), Vec3::ONE);
        let bvh = LightBvh::build(&b.lights, &b.power);
        let p = DVec3::ZERO;
        let ratio = |n: DVec3| bvh.pmf(p, n, 1) / bvh.pmf(p, n, 0);
        assert!(
            (ratio(DVec3::ZERO) - 1.0).abs() < 1e-6,
            "{}",
            ratio(DVec3::ZERO)
        );
        let cos = 0.2 / 4.0;
        for n in [DVec3::Y, -DVec3::Y, DVec3::Y * 3.0] {
            let r = ratio(n);
            assert!((r - cos).abs() < 0.02 * cos, "{n}: ratio {r}, cosine {cos}");
            assert!((bvh.pmf(p, n, 0) + bvh.pmf(p, n, 1) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn cone_union_holds_both_cones() {
        let (w, c) = cone_union(DVec3::Z, 1.0, DVec3::X, 1.0);
        assert!((c - std::f64::consts::FRAC_PI_4.cos()).abs() < 1e-12);
        assert!(w.dot(DVec3::Z) >= c - 1e-12 && w.dot(DVec3::X) >= c - 1e-12);
        assert_eq!(cone_union(DVec3::Z, 1.0, -DVec3::Z, 1.0).1, -1.0);
    }
}
