//! The analytic scenes of tests/tests/whitted.rs and their independent f64 reference: spheres
//! (glass, conductor with eta/k, smooth principled metal and plastic) in front of emissive
//! checker walls under a constant environment, optionally lit by a point light, traced the way
//! `whitted` defines its image (ray–sphere, Snell, exact dielectric and conductor Fresnel,
//! Schlick, both branches followed to max_depth with the same 1e-4 weight cut-off).

use std::f64::consts::PI;

use glam::DVec3;

/// Emission of the two checker colours and the environment.
pub const CHECK_A: [f64; 3] = [2.0, 0.5, 0.25];
pub const CHECK_B: [f64; 3] = [0.2, 0.6, 1.5];
pub const ENV: [f64; 3] = [0.3, 0.4, 0.5];

#[derive(Clone, Copy)]
pub enum Kind {
    Glass {
        eta: f64,
    },
    Conductor {
        eta: DVec3,
        k: DVec3,
    },
    /// principled, metallic 1, roughness below mirror_roughness: a mirror weighted by
    /// Schlick's Fresnel with R0 = base_color (η = 1.5 from the default specular 0.5).
    Metal {
        base: DVec3,
    },
    /// principled, metallic 0, roughness below mirror_roughness: Lambert with base_color lit
    /// by the point light plus the ambient term, and a mirror weighted by F_dielectric(1.5).
    Plastic {
        base: DVec3,
    },
}

#[derive(Clone, Copy)]
pub struct Sphere {
    pub c: DVec3,
    pub r: f64,
    pub kind: Kind,
}

/// One emissive checker cell: the square [x0, x0 + size] × [y0, y0 + size] at z, emitting
/// towards `facing_z` (+1 or −1); its back is black.
#[derive(Clone, Copy)]
pub struct Cell {
    pub x0: f64,
    pub y0: f64,
    pub size: f64,
    pub z: f64,
    pub facing_z: f64,
    pub emission: DVec3,
}

pub struct Analytic {
    pub eye: DVec3,
    pub fov_y: f64,
    pub size: (u32, u32),
    pub spheres: Vec<Sphere>,
    pub cells: Vec<Cell>,
    /// A point light (position, intensity); only in scenes without cells (whose area-light
    /// quadrature the reference does not model).
    pub point: Option<(DVec3, DVec3)>,
}

/// A checker wall of n×n cells of side `size` centred on the z axis at `z`, facing `facing_z`.
pub fn checker(n: i32, size: f64, z: f64, facing_z: f64) -> Vec<Cell> {
    let mut cells = Vec::new();
    let half = n as f64 * size / 2.0;
    for i in 0..n {
        for j in 0..n {
            let e = if (i + j) % 2 == 0 { CHECK_A } else { CHECK_B };
            cells.push(Cell {
                x0: -half + i as f64 * size,
                y0: -half + j as f64 * size,
                size,
                z,
                facing_z,
                emission: DVec3::from(e),
            });
        }
    }
    cells
}

impl Analytic {
    /// The scene JSON: cells as quads (reflectance 0, so only their emission shows).
    pub fn json(&self) -> String {
        let mut materials = vec![
            r#""glass": {"type": "dielectric", "ior": 1.5}"#.to_string(),
            r#""black": {"type": "diffuse", "reflectance": 0}"#.to_string(),
        ];
        let mut objects = Vec::new();
        for (i, c) in self.cells.iter().enumerate() {
            let e = c.emission;
            materials.push(format!(
                r#""cell{i}": {{"type": "diffuse", "reflectance": 0, "emission": [{}, {}, {}]}}"#,
                e.x, e.y, e.z
            ));
            // front normal = normalize(edge_u × edge_v): x × y = +z, y × x = −z.
            let (eu, ev) = if c.facing_z > 0.0 {
                ([c.size, 0.0, 0.0], [0.0, c.size, 0.0])
            } else {
                ([0.0, c.size, 0.0], [c.size, 0.0, 0.0])
            };
            objects.push(format!(
                r#"{{"type": "quad", "origin": [{}, {}, {}], "edge_u": {:?}, "edge_v": {:?}, "material": "cell{i}"}}"#,
                c.x0, c.y0, c.z, eu, ev
            ));
        }
        for (i, s) in self.spheres.iter().enumerate() {
            let m = match s.kind {
                Kind::Glass { .. } => "glass".to_string(),
                Kind::Conductor { eta, k } => {
                    materials.push(format!(
                        r#""metal{i}": {{"type": "conductor", "eta": [{}, {}, {}], "k": [{}, {}, {}]}}"#,
                        eta.x, eta.y, eta.z, k.x, k.y, k.z
                    ));
                    format!("metal{i}")
                }
                Kind::Metal { base } => {
                    materials.push(format!(
                        r#""principled{i}": {{"type": "principled", "base_color": [{}, {}, {}], "metallic": 1, "roughness": 0.05}}"#,
                        base.x, base.y, base.z
                    ));
                    format!("principled{i}")
                }
                Kind::Plastic { base } => {
                    materials.push(format!(
                        r#""plastic{i}": {{"type": "principled", "base_color": [{}, {}, {}], "metallic": 0, "roughness": 0.05}}"#,
                        base.x, base.y, base.z
                    ));
                    format!("plastic{i}")
                }
            };
            objects.push(format!(
                r#"{{"type": "sphere", "center": [{}, {}, {}], "radius": {}, "material": "{m}"}}"#,
                s.c.x, s.c.y, s.c.z, s.r
            ));
        }
        format!(
            r#"{{"version": 1,
  "camera": {{"position": [{}, {}, {}], "look_at": [0, 0, 0], "fov_y": {}}},
  "film": {{"width": {}, "height": {}, "filter": "box"}},
  "materials": {{{}}},
  "objects": [{}],
  "lights": [{}],
  "environment": {{"type": "constant", "radiance": {:?}}}}}"#,
            self.eye.x,
            self.eye.y,
            self.eye.z,
            self.fov_y,
            self.size.0,
            self.size.1,
            materials.join(",\n"),
            objects.join(",\n"),
            self.point
                .map(|(p, i)| format!(
                    r#"{{"type": "point", "position": [{}, {}, {}], "intensity": [{}, {}, {}]}}"#,
                    p.x, p.y, p.z, i.x, i.y, i.z
                ))
                .unwrap_or_default(),
            ENV
        )
    }

    /// The camera ray through film position (fx, fy) in pixels (row 0 at the top).
    pub fn camera_ray(&self, fx: f64, fy: f64) -> (DVec3, DVec3) {
        let forward = (DVec3::ZERO - self.eye).normalize();
        let right = forward.cross(DVec3::Y).normalize();
        let up = right.cross(forward);
        let tan_half = (self.fov_y.to_radians() * 0.5).tan();
        let (w, h) = (self.size.0 as f64, self.size.1 as f64);
        let sx = (2.0 * fx / w - 1.0) * tan_half * (w / h);
        let sy = (1.0 - 2.0 * fy / h) * tan_half;
        (self.eye, (forward + sx * right + sy * up).normalize())
    }

    /// Radiance along (o, d) reaching a chain of `depth` segments so far, times `beta`: what
    /// whitted computes (the shaders' order of operations is irrelevant in f64).
    pub fn trace(&self, o: DVec3, d: DVec3, beta: DVec3, depth: i32, max_depth: i32) -> DVec3 {
        const T_MIN: f64 = 1e-7;
        // Step 1: nearest sphere and cell.
        let mut best = f64::INFINITY;
        let t_sphere = |s: &Sphere, o: DVec3, d: DVec3| -> Option<f64> {
            let oc = o - s.c;
            let b = oc.dot(d);
            let c = oc.length_squared() - s.r * s.r;
            let disc = b * b - c;
            if disc < 0.0 {
                return None;
            }
            let sq = disc.sqrt();
            [-b - sq, -b + sq].into_iter().find(|&t| t > T_MIN)
        };
        let mut hit_sphere = None;
        for s in &self.spheres {
            let oc = o - s.c;
            let b = oc.dot(d);
            let c = oc.length_squared() - s.r * s.r;
            let disc = b * b - c;
            if disc < 0.0 {
                continue;
            }
            let sq = disc.sqrt();
            for t in [-b - sq, -b + sq] {
                if t > T_MIN && t < best {
                    best = t;
                    hit_sphere = Some(*s);
                    break;
                }
            }
        }
        let mut hit_cell = None;
        for c in &self.cells {
            if d.z == 0.0 {
                continue;
            }
            let t = (c.z - o.z) / d.z;
            if !(t > T_MIN && t < best) {
                continue;
            }
            let p = o + t * d;
            if p.x >= c.x0 && p.x <= c.x0 + c.size && p.y >= c.y0 && p.y <= c.y0 + c.size {
                best = t;
                hit_cell = Some(*c);
                hit_sphere = None;
            }
        }
        // Step 2: escaping rays see the environment; cells show their emission (front only)
        // and reflect nothing.
        if let Some(c) = hit_cell {
            return if d.z * c.facing_z < 0.0 {
                beta * c.emission
            } else {
                DVec3::ZERO
            };
        }
        let Some(s) = hit_sphere else {
            return beta * DVec3::from(ENV);
        };
        // Step 3: no emission on spheres; stop where max_depth says so.
        if depth + 1 >= max_depth {
            return DVec3::ZERO;
        }
        let p = o + best * d;
        let n = (p - s.c).normalize();
        let wo = -d;
        let cos_i = wo.dot(n);
        let reflected = -wo + 2.0 * cos_i * n;
        let mut out = DVec3::ZERO;
        let follow = |dir: DVec3, w: DVec3, out: &mut DVec3| {
            if w.max_element() >= 1e-4 {
                *out += self.trace(p, dir, w, depth + 1, max_depth);
            }
        };
        match s.kind {
            Kind::Glass { eta } => {
                // Step 4: exact dielectric Fresnel, η flipped inside, total internal reflection.
                let f = fresnel_dielectric(cos_i, eta);
                if f >= 1.0 {
                    follow(reflected, beta, &mut out);
                    return out;
                }
                let eta_ti = if cos_i >= 0.0 { 1.0 / eta } else { eta };
                let ct = (1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti).sqrt();
                // Snell: tangential part scaled by η_ti, normal part across the interface.
                let t_dir = (-eta_ti * (wo - cos_i * n) - cos_i.signum() * ct * n).normalize();
                follow(reflected, beta * f, &mut out);
                follow(t_dir, beta * ((1.0 - f) * eta_ti * eta_ti), &mut out);
            }
            Kind::Conductor { eta, k } => {
                // Step 4: conductor Fresnel (Mitsuba's fresnel_conductor), per channel.
                let f = DVec3::new(
                    fresnel_conductor(cos_i.abs(), eta.x, k.x),
                    fresnel_conductor(cos_i.abs(), eta.y, k.y),
                    fresnel_conductor(cos_i.abs(), eta.z, k.z),
                );
                follow(reflected, beta * f, &mut out);
            }
            Kind::Plastic { base } => {
                // Step 4: Lambert lit by the point light (shadow rays stop at any sphere)...
                assert!(
                    self.cells.is_empty(),
                    "plastic with area lights is not modelled"
                );
                if let Some((lp, intensity)) = self.point {
                    let l = lp - p;
                    let dist = l.length();
                    let wl = l / dist;
                    let cos = n.dot(wl);
                    let blocked = self
                        .spheres
                        .iter()
                        .any(|s| t_sphere(s, p, wl).is_some_and(|t| t < dist));
                    if cos > 0.0 && !blocked {
                        out += beta * base * intensity * (cos / (PI * dist * dist));
                    }
                }
                // ... plus ambient (albedo × the constant environment) and the coat's mirror.
                out += beta * base * DVec3::from(ENV);
                follow(reflected, beta * fresnel_dielectric(cos_i, 1.5), &mut out);
            }
            Kind::Metal { base } => {
                // Step 4: Schlick: R0 + (1 − R0)(1 − cos θ)^5 (outside, η > 1).
                let w = (1.0 - cos_i.abs()).clamp(0.0, 1.0).powi(5);
                follow(reflected, beta * (base + (DVec3::ONE - base) * w), &mut out);
            }
        }
        out
    }

    /// The f64 image at pixel centres, and per pixel whether it is stable under a nudge of
    /// 1/1000 pixel in x and y (else it straddles an edge and f32 rounding may flip it).
    pub fn reference(&self, max_depth: i32) -> (Vec<DVec3>, Vec<bool>) {
        let (w, h) = self.size;
        let mut img = Vec::new();
        let mut stable = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
                let (o, d) = self.camera_ray(fx, fy);
                let l = self.trace(o, d, DVec3::ONE, 0, max_depth);
                let mut ok = true;
                for (dx, dy) in [(1e-3, 0.0), (-1e-3, 0.0), (0.0, 1e-3), (0.0, -1e-3)] {
                    let (o2, d2) = self.camera_ray(fx + dx, fy + dy);
                    let l2 = self.trace(o2, d2, DVec3::ONE, 0, max_depth);
                    if (l2 - l).abs().max_element() > 1e-4 * (1.0 + l.max_element()) {
                        ok = false;
                    }
                }
                img.push(l);
                stable.push(ok);
            }
        }
        (img, stable)
    }
}

/// Unpolarised dielectric Fresnel reflectance for the signed incident cosine (η flipped
/// inside; 1 on total internal reflection).
pub fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let eta_ti = if cos_i >= 0.0 { 1.0 / eta } else { eta };
    let eta_it = 1.0 / eta_ti;
    let cos_t2 = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti;
    if cos_t2 <= 0.0 {
        return 1.0;
    }
    let (ci, ct) = (cos_i.abs(), cos_t2.sqrt());
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    0.5 * (a_s * a_s + a_p * a_p)
}

/// Unpolarised conductor Fresnel for complex IOR eta + ik (Mitsuba `fresnel_conductor`).
pub fn fresnel_conductor(cos_i: f64, eta: f64, k: f64) -> f64 {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let temp1 = eta * eta - k * k - s2;
    let a2pb2 = (temp1 * temp1 + 4.0 * k * k * eta * eta).sqrt();
    let a = (0.5 * (a2pb2 + temp1)).max(0.0).sqrt();
    let term1 = a2pb2 + c2;
    let term2 = 2.0 * cos_i * a;
    let rs = (term1 - term2) / (term1 + term2);
    let term3 = a2pb2 * c2 + s4;
    let term4 = term2 * s2;
    let rp = rs * (term3 - term4) / (term3 + term4);
    0.5 * (rs + rp)
}
