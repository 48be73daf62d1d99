//! GPU unit tests of the BSDFs (`shaders/common/bsdf/*.glsl`), driven through
//! `shaders/tests/bsdf_check.comp` (its header gives the method and buffer layout) on the default
//! device (lavapipe in CI) with the validation layer on (any validation message fails the test).
//! Method after pbrt-v4's BSDF tests and Mitsuba 3's BSDF tests, reduced to moments.
//!
//! Each material of the table (one test per family: diffuse + conductor, dielectric,
//! principled, phong) runs at every wo of `wos()`: normal, 45°, grazing z = 1e-3, 45° below the
//! horizon (the mirror image of the 45° wo) and exactly grazing z = 0, in R = 16 replicas of
//! N = 64 · 128 = 8192 stratified samples with independent random shifts; σ is the standard error
//! of the replica mean. Asserted for every (material, wo):
//! - no NaN/Inf in any output (sample, eval, pdf, albedo hint);
//! - sample weight == bsdf_eval / bsdf_pdf at the sampled direction, and sample pdf == bsdf_pdf,
//!   both within 1e-3 relative as the maximum mismatch over all non-delta samples;
//! - energy conservation: albedo (Σ weight / N, max channel) <= 1 + 3σ + 1e-5, in importance mode
//!   for transmissive materials (radiance-mode transmission is scaled by 1/η² and legitimately
//!   exceeds 1 from inside: 1.20 for roughness 0.3, ior 1.5 at 45° below; such cases are only
//!   checked for consistency, the smooth one analytically). Mitsuba 3's principled BSDF is not energy conserving (diffuse,
//!   retro-reflection, sheen and clearcoat are added to the specular lobe without compensation):
//!   of the principled cases here, sheen 1 (at grazing wo: 1.078) and white base colour with
//!   specular 1 and roughness 0.2 (1.068 normal, 1.079 at 45°, 1.260 grazing) exceed 1, as in
//!   Mitsuba; every principled albedo must match Mitsuba 3.9.1 scalar_rgb's for the same
//!   parameters (`MITSUBA_PRINCIPLED`) within 4σ + 1e-3, and the other principled cases must not
//!   exceed 1;
//! - analytic albedos: diffuse = reflectance within 1e-5 (white furnace: reflectance 1 gives 1);
//!   a smooth conductor = reflectance · F(cos θo): exactly 1 with reflectance 1 and no eta/k, and
//!   with gold's eta/k within 1e-4 of the complex Fresnel equations evaluated on the host; a smooth
//!   dielectric = R·F + T·(1 − F)·s within 1e-3, s = 1 in importance mode (so reflectance =
//!   transmittance = 1 gives exactly 1 from both sides: the energy-conserving furnace) and
//!   s = 1/η² along the path in radiance mode;
//! - ∫pdf dω (uniform-sphere estimate) == 1 − delta fraction − failed fraction within
//!   0.01 + 4σ; the uniform-sphere estimate is useless for sharp lobes, so the check is skipped for
//!   cases marked sharp (rough dielectrics with roughness 0.3 or ior 1.0001 whose transmitted lobe
//!   is nearly a delta, principled spec_trans roughness 0.1, phong n = 1000) or sharp at grazing
//!   (microfacet reflectors with roughness <= 0.4 at z = 1e-3), and it fails if a checked
//!   estimate has σ > 0.02, so it is never vacuous;
//! - sidedness: a reflection-only material below the horizon is black (every sample fails, pdf 0)
//!   when one-sided, and for two-sided ones its albedo equals that of the mirrored wo within
//!   4σ + 1e-4; at exactly grazing wo (z = 0) every material is black.
//! The measured values are printed as one table per family.

mod common;
use common::context;

use std::sync::Arc;

use renderer::gpu::{compile_glsl, Binding, Buffer, BufferUsage, ComputePipeline, GpuContext};

const MAT_DIFFUSE: u32 = 0;
const MAT_CONDUCTOR: u32 = 1;
const MAT_DIELECTRIC: u32 = 2;
const MAT_PRINCIPLED: u32 = 3;
const MAT_PHONG: u32 = 4;
const MATF_TWO_SIDED: u32 = 1;
const MATF_HAS_ETA_K: u32 = 2;
const RADIANCE: u32 = 0;
const IMPORTANCE: u32 = 1;

/// Binding indices of bsdf_check.comp.
const BINDING_CASES: u32 = 0;
const BINDING_WOS: u32 = 1;
const BINDING_RESULTS: u32 = 2;

/// Samples per thread (N = 64 · SPT per replica) and replicas.
const SPT: u32 = 128;
const REPLICAS: usize = 16;
/// Threshold on the max relative mismatch of weight vs eval/pdf and of pdf vs bsdf_pdf.
const MISMATCH_TOL: f64 = 1e-3;
/// ∫pdf check: |∫pdf − (1 − δ − fail)| <= PDF_GAP_TOL + 4σ, run only where σ <= PDF_GAP_MAX_SIGMA
/// (a case whose estimate is noisier must be marked sharp, so the check is never vacuous).
const PDF_GAP_TOL: f64 = 0.01;
const PDF_GAP_MAX_SIGMA: f64 = 0.02;
/// Index of the grazing wo (z = 1e-3) in WOS.
const WO_GRAZING: usize = 2;

/// The wo directions, in the local frame; all at φ = 30° so that "below" mirrors "45°".
const WO_NAMES: [&str; 5] = ["normal", "45°", "z=1e-3", "below 45°", "z=0"];

fn wos() -> Vec<[f64; 3]> {
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let at = |z: f64| {
        let r = (1.0 - z * z).max(0.0).sqrt();
        [r * c, r * s, z]
    };
    let h = std::f64::consts::FRAC_1_SQRT_2;
    vec![[0.0, 0.0, 1.0], at(h), at(1e-3), at(-h), at(0.0)]
}

/// What a material's albedo may do.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Energy {
    /// Albedo <= 1 + 3σ.
    Conserving,
    /// Exceeds 1 by design, as Mitsuba's principled does for these parameters (compared with
    /// Mitsuba's albedos instead).
    ExceedsLikeMitsuba,
    /// Radiance-mode transmission: scaled by 1/η², may exceed 1 from inside.
    Radiance,
}

#[derive(Clone)]
struct Case {
    name: String,
    ty: u32,
    flags: u32,
    mode: u32,
    c0: [f32; 3],
    c1: [f32; 3],
    c2: [f32; 3],
    s: [f32; 12],
    energy: Energy,
    /// Where the ∫pdf check applies.
    pdf_integral: PdfIntegral,
}

/// Which wos the ∫pdf check runs at (the uniform-sphere estimate of ∫pdf has a variance that
/// grows with ∫pdf², so it is useless for sharp lobes).
#[derive(Clone, Copy, PartialEq, Debug)]
enum PdfIntegral {
    Always,
    NotGrazing,
    Never,
}

impl Case {
    fn new(name: &str, ty: u32, flags: u32, mode: u32) -> Case {
        Case {
            name: name.to_string(),
            ty,
            flags,
            mode,
            c0: [0.0; 3],
            c1: [0.0; 3],
            c2: [0.0; 3],
            s: [0.0; 12],
            energy: Energy::Conserving,
            pdf_integral: PdfIntegral::Always,
        }
    }
    fn c0(mut self, v: [f32; 3]) -> Case {
        self.c0 = v;
        self
    }
    fn c1(mut self, v: [f32; 3]) -> Case {
        self.c1 = v;
        self
    }
    fn c2(mut self, v: [f32; 3]) -> Case {
        self.c2 = v;
        self
    }
    fn s(mut self, i: usize, v: f32) -> Case {
        self.s[i] = v;
        self
    }
    fn one_sided(mut self) -> Case {
        self.flags &= !MATF_TWO_SIDED;
        self
    }
    /// Lobes too sharp for the uniform-sphere ∫pdf estimate at every wo.
    fn sharp(mut self) -> Case {
        self.pdf_integral = PdfIntegral::Never;
        self
    }
    /// Lobes too sharp for the uniform-sphere ∫pdf estimate at the grazing wo (z = 1e-3) only.
    fn sharp_grazing(mut self) -> Case {
        self.pdf_integral = PdfIntegral::NotGrazing;
        self
    }
    fn energy(mut self, e: Energy) -> Case {
        self.energy = e;
        self
    }
    fn reflection_only(&self) -> bool {
        matches!(self.ty, MAT_DIFFUSE | MAT_CONDUCTOR | MAT_PHONG)
            || (self.ty == MAT_PRINCIPLED && !(self.s[7] > 0.0))
    }
    fn two_sided(&self) -> bool {
        self.flags & MATF_TWO_SIDED != 0
    }
    fn is_delta(&self) -> bool {
        match self.ty {
            MAT_CONDUCTOR => {
                let r = self.s[0].clamp(0.0, 1.0) as f64;
                let a = self.s[1].clamp(0.0, 1.0) as f64;
                let aspect = (1.0 - 0.9 * a).sqrt();
                (r * r / aspect) < 1e-3
            }
            MAT_DIELECTRIC => (self.s[0].clamp(0.0, 1.0) as f64).powi(2) < 1e-3,
            _ => false,
        }
    }
    /// The 7 vec4s of bsdf_check.comp's case layout.
    fn pack(&self) -> [[f32; 4]; 7] {
        let s = &self.s;
        [
            [self.ty as f32, self.flags as f32, self.mode as f32, 0.0],
            [self.c0[0], self.c0[1], self.c0[2], 0.0],
            [self.c1[0], self.c1[1], self.c1[2], 0.0],
            [self.c2[0], self.c2[1], self.c2[2], 0.0],
            [s[0], s[1], s[2], s[3]],
            [s[4], s[5], s[6], s[7]],
            [s[8], s[9], s[10], s[11]],
        ]
    }
}

fn grey(v: f32) -> [f32; 3] {
    [v, v, v]
}

/// Gold at ~(650, 550, 450) nm (complex IOR eta + ik, as Mitsuba's "Au").
const GOLD_ETA: [f32; 3] = [0.143, 0.374, 1.442];
const GOLD_K: [f32; 3] = [3.983, 2.385, 1.603];

/// Principled with Mitsuba 3's defaults (base_color 0.5, roughness 0.5, specular 0.5, all else 0).
/// Slots: s[0] metallic, s[1] roughness, s[2] specular, s[3] spec_tint, s[4] anisotropic,
/// s[5] sheen, s[6] sheen_tint, s[7] spec_trans, s[8] eta (<= 0: from specular), s[9] flatness,
/// s[10] clearcoat, s[11] clearcoat_gloss.
fn principled(name: &str, mode: u32) -> Case {
    Case::new(name, MAT_PRINCIPLED, MATF_TWO_SIDED, mode)
        .c0(grey(0.5))
        .s(1, 0.5)
        .s(2, 0.5)
}

/// One (case, wo) result, aggregated over the replicas.
#[derive(Clone, Debug, Default)]
struct Stat {
    /// Albedo (max channel of non-delta + delta), mean and standard error over replicas.
    albedo: f64,
    albedo_sigma: f64,
    /// Albedo per channel (mean).
    albedo_rgb: [f64; 3],
    delta_albedo: f64,
    mismatch_weight: f64,
    mismatch_pdf: f64,
    frac_weight_bad: f64,
    frac_pdf_bad: f64,
    bad: f64,
    pdf_integral: f64,
    delta_frac: f64,
    fail_frac: f64,
    /// ∫pdf − (1 − delta − fail): mean and standard error.
    pdf_gap: f64,
    pdf_gap_sigma: f64,
}

fn mean_sigma(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Runs bsdf_check.comp over cases × WOS × REPLICAS and aggregates per (case, wo).
fn run_cases(ctx: &Arc<GpuContext>, cases: &[Case], seed: u32) -> Vec<Vec<Stat>> {
    let wos = wos();
    let mut case_data: Vec<[f32; 4]> = Vec::new();
    for _ in 0..REPLICAS {
        for c in cases {
            case_data.extend_from_slice(&c.pack());
        }
    }
    let wo_data: Vec<[f32; 4]> = wos
        .iter()
        .map(|w| [w[0] as f32, w[1] as f32, w[2] as f32, 0.0])
        .collect();
    let num_cases = (cases.len() * REPLICAS) as u32;
    let num_pairs = num_cases as usize * wos.len();

    let spirv =
        compile_glsl("tests/bsdf_check.comp", &Vec::new()).expect("compile bsdf_check.comp");
    let case_buf = Buffer::from_slice(ctx, "bsdf cases", &case_data).expect("cases");
    let wo_buf = Buffer::from_slice(ctx, "bsdf wos", &wo_data).expect("wos");
    let result_buf = Buffer::new(
        ctx,
        "bsdf results",
        (num_pairs * 4 * 16) as u64,
        BufferUsage::Storage,
    )
    .expect("results");
    ctx.fill_zero(&result_buf).expect("fill");
    let pipeline = ComputePipeline::new(
        ctx,
        "bsdf_check",
        &spirv,
        &[
            Binding {
                index: BINDING_CASES,
                buffer: &case_buf,
            },
            Binding {
                index: BINDING_WOS,
                buffer: &wo_buf,
            },
            Binding {
                index: BINDING_RESULTS,
                buffer: &result_buf,
            },
        ],
        16,
    )
    .expect("pipeline");
    let push: [u32; 4] = [num_cases, wos.len() as u32, SPT, seed];
    let gx = (num_pairs as u32).min(65535);
    let gy = (num_pairs as u32).div_ceil(gx);
    ctx.record(1, |rec| {
        rec.dispatch(
            &pipeline,
            bytemuck::bytes_of(&push),
            [gx, gy, 1],
            "bsdf_check",
        )
    })
    .expect("dispatch");
    let r = ctx
        .download_vec::<[f32; 4]>(&result_buf, num_pairs * 4)
        .expect("download");

    let mut out = vec![vec![Stat::default(); wos.len()]; cases.len()];
    for (ci, row) in out.iter_mut().enumerate() {
        for (wi, st) in row.iter_mut().enumerate() {
            let mut albedo = Vec::new();
            let mut gap = Vec::new();
            let mut rgb = [0.0f64; 3];
            for rep in 0..REPLICAS {
                let pair = (rep * cases.len() + ci) * wos.len() + wi;
                let [a, b, c, d] = [
                    r[4 * pair],
                    r[4 * pair + 1],
                    r[4 * pair + 2],
                    r[4 * pair + 3],
                ];
                let total: Vec<f64> = (0..3).map(|k| a[k] as f64 + b[k] as f64).collect();
                for k in 0..3 {
                    rgb[k] += total[k] / REPLICAS as f64;
                }
                albedo.push(total.iter().cloned().fold(f64::MIN, f64::max));
                st.delta_albedo +=
                    (0..3).map(|k| b[k] as f64).fold(f64::MIN, f64::max) / REPLICAS as f64;
                st.mismatch_weight = st.mismatch_weight.max(a[3] as f64);
                st.mismatch_pdf = st.mismatch_pdf.max(b[3] as f64);
                st.bad += c[0] as f64;
                st.pdf_integral += c[1] as f64 / REPLICAS as f64;
                st.delta_frac += c[2] as f64 / REPLICAS as f64;
                st.fail_frac += c[3] as f64 / REPLICAS as f64;
                st.frac_weight_bad += d[0] as f64 / REPLICAS as f64;
                st.frac_pdf_bad += d[1] as f64 / REPLICAS as f64;
                gap.push(c[1] as f64 - (1.0 - c[2] as f64 - c[3] as f64));
            }
            (st.albedo, st.albedo_sigma) = mean_sigma(&albedo);
            (st.pdf_gap, st.pdf_gap_sigma) = mean_sigma(&gap);
            st.albedo_rgb = rgb;
        }
    }
    out
}

fn print_table(family: &str, cases: &[Case], stats: &[Vec<Stat>]) {
    println!(
        "\n== {family}: N = {} per replica, {REPLICAS} replicas; albedo = max channel ==",
        64 * SPT
    );
    println!(
        "{:<30} {:<9} {:>8} {:>8} {:>8} {:>9} {:>9} {:>7} {:>7} {:>6} {:>6} {:>8} {:>7} {:>4}",
        "material",
        "wo",
        "albedo",
        "σ",
        "delta",
        "mm_w",
        "mm_pdf",
        "∫pdf",
        "1-δ-f",
        "δ",
        "fail",
        "gap",
        "σ_gap",
        "nan"
    );
    for (c, row) in cases.iter().zip(stats) {
        for (wi, st) in row.iter().enumerate() {
            println!(
                "{:<30} {:<9} {:>8.5} {:>8.1e} {:>8.5} {:>9.2e} {:>9.2e} {:>7.4} {:>7.4} {:>6.3} {:>6.3} {:>8.1e} {:>7.1e} {:>4}",
                c.name,
                WO_NAMES[wi],
                st.albedo,
                st.albedo_sigma,
                st.delta_albedo,
                st.mismatch_weight,
                st.mismatch_pdf,
                st.pdf_integral,
                1.0 - st.delta_frac - st.fail_frac,
                st.delta_frac,
                st.fail_frac,
                st.pdf_gap,
                st.pdf_gap_sigma,
                st.bad
            );
        }
    }
}

// ---- host references --------------------------------------------------------------------------

/// Unpolarised dielectric Fresnel reflectance and the transmitted-side scale η_ti² for a smooth
/// interface with relative IOR eta (inside / outside), incident cosine `cos_i` (signed).
fn fresnel_dielectric(cos_i: f64, eta: f64) -> (f64, f64) {
    let (eta_it, cos_i) = if cos_i >= 0.0 {
        (eta, cos_i)
    } else {
        (1.0 / eta, -cos_i)
    };
    let sin2_t = (1.0 - cos_i * cos_i) / (eta_it * eta_it);
    if sin2_t >= 1.0 {
        return (1.0, 0.0);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
    let rp = (eta_it * cos_i - cos_t) / (eta_it * cos_i + cos_t);
    (0.5 * (rs * rs + rp * rp), 1.0 / (eta_it * eta_it))
}

/// Minimal complex arithmetic for the conductor Fresnel reference.
#[derive(Clone, Copy)]
struct C(f64, f64);
impl C {
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C(
            (self.0 * o.0 + self.1 * o.1) / d,
            (self.1 * o.0 - self.0 * o.1) / d,
        )
    }
    fn sqrt(self) -> C {
        let r = (self.0 * self.0 + self.1 * self.1).sqrt();
        let re = ((r + self.0) / 2.0).sqrt();
        let im = ((r - self.0) / 2.0).sqrt().copysign(self.1);
        C(re, im)
    }
    fn norm2(self) -> f64 {
        self.0 * self.0 + self.1 * self.1
    }
}

/// Unpolarised Fresnel reflectance of a conductor with complex IOR n = eta + ik, straight from
/// the complex Fresnel equations (cos θt = sqrt(1 − sin²θi / n²)).
fn fresnel_conductor(cos_i: f64, eta: f64, k: f64) -> f64 {
    let n = C(eta, k);
    let ci = C(cos_i, 0.0);
    let sin2 = C(1.0 - cos_i * cos_i, 0.0);
    let ct = C(1.0, 0.0).sub(sin2.div(n.mul(n))).sqrt();
    let rs = ci.sub(n.mul(ct)).div(ci.add(n.mul(ct)));
    let rp = n.mul(ci).sub(ct).div(n.mul(ci).add(ct));
    0.5 * (rs.norm2() + rp.norm2())
}

/// Expected albedo (max channel) with its tolerance where an analytic value exists.
fn analytic_albedo(c: &Case, wo: [f64; 3]) -> Option<(f64, f64)> {
    let z = wo[2];
    let front_z = if c.reflection_only() {
        if z == 0.0 || (z < 0.0 && !c.two_sided()) {
            return Some((0.0, 0.0));
        }
        z.abs()
    } else {
        if z == 0.0 {
            return Some((0.0, 0.0));
        }
        z
    };
    let maxc = |v: [f64; 3]| v.iter().cloned().fold(f64::MIN, f64::max);
    match c.ty {
        MAT_DIFFUSE => Some((maxc(c.c0.map(|x| x as f64)), 1e-5)),
        MAT_CONDUCTOR if c.is_delta() => {
            let f = |i: usize| {
                let fr = if c.flags & MATF_HAS_ETA_K != 0 {
                    fresnel_conductor(front_z, c.c1[i] as f64, c.c2[i] as f64)
                } else {
                    1.0
                };
                c.c0[i] as f64 * fr
            };
            let tol = if c.flags & MATF_HAS_ETA_K != 0 {
                1e-4
            } else {
                0.0
            };
            Some((maxc([f(0), f(1), f(2)]), tol))
        }
        MAT_DIELECTRIC if c.is_delta() => {
            let eta = (c.s[1] as f64).max(1e-3);
            let (f, scale) = fresnel_dielectric(front_z, eta);
            let scale = if c.mode == RADIANCE { scale } else { 1.0 };
            let a = |i: usize| c.c0[i] as f64 * f + c.c1[i] as f64 * (1.0 - f) * scale;
            Some((maxc([a(0), a(1), a(2)]), 1e-3))
        }
        _ => None,
    }
}

/// Albedos (max channel) of Mitsuba 3.9.1 scalar_rgb's `principled` BSDF, by BSDF sampling:
/// (name, albedo at WOS[0..4], standard error), 8 × 2^16 independent samples per value.
/// Mitsuba's principled has no twosided wrapper, so its "below 45°" values belong with the
/// one-sided case; two-sided reflectors below the horizon are checked against their mirror image
/// instead (NaN: no reference). Computed offline (not at test time) with:
/// ```python
/// import math, random, mitsuba as mi
/// mi.set_variant('scalar_rgb')
/// rgb = lambda v: {'type': 'rgb', 'value': v}
/// bsdf = mi.load_dict({'type': 'principled', 'base_color': rgb([0.5] * 3), 'roughness': 0.5,
///                      'specular': 0.5})  # plus the case's parameters ('eta' replaces 'specular')
/// si = mi.SurfaceInteraction3f(); si.wi = mi.Vector3f(wo); si.sh_frame = mi.Frame3f([0, 0, 1])
/// ctx = mi.BSDFContext(mi.TransportMode.Radiance)  # Importance for the spec_trans cases
/// rng = random.Random(seed); acc = [0.0] * 3
/// for _ in range(1 << 16):
///     _, w = bsdf.sample(ctx, si, rng.random(), mi.Point2f(rng.random(), rng.random()))
///     acc = [a + (float(w[k]) if math.isfinite(float(w[k])) else 0.0) for k, a in enumerate(acc)]
/// albedo = max(acc) / (1 << 16)   # mean and standard error over seeds 1234..1241
/// ```
#[rustfmt::skip]
const MITSUBA_PRINCIPLED: &[(&str, [f64; 4], [f64; 4])] = &[
    ("principled default",              [0.5399, 0.5480, 0.6872, f64::NAN], [1.8e-4, 2.6e-4, 3.1e-4, 0.0]),
    ("principled default one-sided",    [0.5399, 0.5480, 0.6872, 0.0],      [1.8e-4, 2.6e-4, 3.1e-4, 0.0]),
    ("principled metallic r0.3",        [0.8916, 0.8871, 0.8736, f64::NAN], [1.3e-4, 1.4e-4, 1.6e-4, 0.0]),
    ("principled clearcoat",            [0.8703, 0.8663, 0.9889, f64::NAN], [3.4e-4, 5.8e-4, 5.6e-4, 0.0]),
    ("principled sheen",                [0.8418, 0.8545, 1.0766, f64::NAN], [3.0e-4, 4.3e-4, 4.2e-4, 0.0]),
    ("principled spec_trans r0.5",      [0.9924, 0.9799, 0.8382, 0.8634],   [8.8e-5, 1.2e-4, 1.7e-4, 3.5e-4]),
    ("principled spec_trans r0.1",      [1.0000, 1.0000, 0.9290, 0.9998],   [2.5e-6, 5.4e-6, 2.2e-4, 1.1e-5]),
    ("principled aniso0.8 met0.5 r0.4", [0.7910, 0.7835, 0.8265, f64::NAN], [2.7e-4, 3.3e-4, 2.2e-4, 0.0]),
    ("principled white r0.2 spec1",     [1.0674, 1.0782, 1.2605, f64::NAN], [1.0e-3, 8.5e-4, 3.3e-4, 0.0]),
];
/// Agreement with Mitsuba: |ours − Mitsuba| <= 4 · sqrt(σ_ours² + σ_Mitsuba²) + this.
const MITSUBA_TOL: f64 = 1e-3;

// ---- assertions -------------------------------------------------------------------------------

fn check(cases: &[Case], stats: &[Vec<Stat>]) -> Vec<String> {
    let wos = wos();
    let mut failures = Vec::new();
    let mut fail = |msg: String| failures.push(msg);
    for (c, row) in cases.iter().zip(stats) {
        for (wi, st) in row.iter().enumerate() {
            let at = format!("{} @ {}", c.name, WO_NAMES[wi]);
            if st.bad > 0.0 {
                fail(format!("{at}: {} NaN/Inf outputs", st.bad));
            }
            if st.mismatch_weight > MISMATCH_TOL {
                fail(format!(
                    "{at}: weight vs eval/pdf mismatch {:.2e} (fraction of samples over 1e-3: {:.2e})",
                    st.mismatch_weight, st.frac_weight_bad
                ));
            }
            if st.mismatch_pdf > MISMATCH_TOL {
                fail(format!(
                    "{at}: pdf vs bsdf_pdf mismatch {:.2e} (fraction of samples over 1e-3: {:.2e})",
                    st.mismatch_pdf, st.frac_pdf_bad
                ));
            }
            if c.energy == Energy::Conserving && st.albedo > 1.0 + 3.0 * st.albedo_sigma + 1e-5 {
                fail(format!(
                    "{at}: albedo {:.5} > 1 + 3σ (σ = {:.1e})",
                    st.albedo, st.albedo_sigma
                ));
            }
            if let Some((want, tol)) = analytic_albedo(c, wos[wi]) {
                if (st.albedo - want).abs() > tol {
                    fail(format!(
                        "{at}: albedo {:.6}, analytic {want:.6} (tolerance {tol:e})",
                        st.albedo
                    ));
                }
            }
            let check_integral = match c.pdf_integral {
                PdfIntegral::Always => true,
                PdfIntegral::NotGrazing => wi != WO_GRAZING,
                PdfIntegral::Never => false,
            };
            if check_integral && st.pdf_gap_sigma > PDF_GAP_MAX_SIGMA {
                fail(format!(
                    "{at}: the ∫pdf estimate is too noisy to check (σ {:.1e} > {PDF_GAP_MAX_SIGMA}): mark the case sharp",
                    st.pdf_gap_sigma
                ));
            }
            if check_integral && st.pdf_gap.abs() > PDF_GAP_TOL + 4.0 * st.pdf_gap_sigma {
                fail(format!(
                    "{at}: ∫pdf {:.4} vs 1 − δ − fail {:.4} (gap {:.2e}, σ {:.1e})",
                    st.pdf_integral,
                    1.0 - st.delta_frac - st.fail_frac,
                    st.pdf_gap,
                    st.pdf_gap_sigma
                ));
            }
            let z = wos[wi][2];
            let black = z == 0.0 || (z < 0.0 && c.reflection_only() && !c.two_sided());
            if black && (st.fail_frac != 1.0 || st.albedo != 0.0 || st.pdf_integral != 0.0) {
                fail(format!(
                    "{at}: should be black (fail fraction {}, albedo {}, ∫pdf {})",
                    st.fail_frac, st.albedo, st.pdf_integral
                ));
            }
        }
        // Two-sided reflectors: below the horizon mirrors the 45° wo
        if c.reflection_only() && c.two_sided() {
            let (up, down) = (&row[1], &row[3]);
            let tol = 4.0 * (up.albedo_sigma.powi(2) + down.albedo_sigma.powi(2)).sqrt() + 1e-4;
            if (up.albedo - down.albedo).abs() > tol {
                fail(format!(
                    "{}: two-sided albedo below {:.5} vs above {:.5} (tolerance {tol:.1e})",
                    c.name, down.albedo, up.albedo
                ));
            }
        }
    }
    failures
}

/// Runs and prints one family; `extra` adds family-specific checks. Fails with every failure.
fn run_family(
    family: &str,
    cases: &[Case],
    seed: u32,
    extra: impl FnOnce(&[Case], &[Vec<Stat>]) -> Vec<String>,
) {
    let ctx = context();
    let t0 = std::time::Instant::now();
    let stats = run_cases(&ctx, cases, seed);
    print_table(family, cases, &stats);
    println!("({family}: {:.1} s)", t0.elapsed().as_secs_f64());
    let mut failures = check(cases, &stats);
    failures.extend(extra(cases, &stats));
    if let Err(e) = ctx.check_validation() {
        panic!("validation layer: {e}");
    }
    assert!(
        failures.is_empty(),
        "{family}: {} failures:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

fn no_extra(_: &[Case], _: &[Vec<Stat>]) -> Vec<String> {
    Vec::new()
}

// ---- the material table -----------------------------------------------------------------------

#[test]
fn diffuse_and_conductor() {
    let cond = |name: &str, r: f32, aniso: f32, gold: bool| {
        let c = Case::new(name, MAT_CONDUCTOR, MATF_TWO_SIDED, RADIANCE)
            .c0(grey(1.0))
            .s(0, r)
            .s(1, aniso);
        if gold {
            let mut c = c.c1(GOLD_ETA).c2(GOLD_K);
            c.flags |= MATF_HAS_ETA_K;
            c
        } else {
            c
        }
    };
    let cases = vec![
        Case::new(
            "diffuse 0.8 two-sided",
            MAT_DIFFUSE,
            MATF_TWO_SIDED,
            RADIANCE,
        )
        .c0([0.8, 0.5, 0.2]),
        Case::new("diffuse 0.8 one-sided", MAT_DIFFUSE, 0, RADIANCE).c0(grey(0.8)),
        Case::new("diffuse 1 (furnace)", MAT_DIFFUSE, MATF_TWO_SIDED, RADIANCE).c0(grey(1.0)),
        cond("conductor smooth", 0.0, 0.0, false),
        cond("conductor smooth gold", 0.0, 0.0, true),
        cond("conductor smooth one-sided", 0.0, 0.0, false).one_sided(),
        cond("conductor r0.3", 0.3, 0.0, false).sharp_grazing(),
        cond("conductor r0.3 gold", 0.3, 0.0, true).sharp_grazing(),
        cond("conductor r0.7", 0.7, 0.0, false),
        cond("conductor r0.7 gold", 0.7, 0.0, true),
        cond("conductor r0.4 aniso0.8", 0.4, 0.8, false).sharp_grazing(),
        cond("conductor r0.4 aniso0.8 gold", 0.4, 0.8, true).sharp_grazing(),
        cond("conductor r0.3 one-sided", 0.3, 0.0, false)
            .one_sided()
            .sharp_grazing(),
    ];
    run_family("diffuse and conductor", &cases, 1, no_extra);
}

#[test]
fn dielectric() {
    let diel = |name: &str, r: f32, ior: f32, mode: u32| {
        Case::new(name, MAT_DIELECTRIC, 0, mode)
            .c0(grey(1.0))
            .c1(grey(1.0))
            .s(0, r)
            .s(1, ior)
    };
    let cases = vec![
        diel("smooth 1.5 (furnace)", 0.0, 1.5, IMPORTANCE),
        diel("smooth 1.33 (furnace)", 0.0, 1.33, IMPORTANCE),
        diel("smooth 1.0001 (furnace)", 0.0, 1.0001, IMPORTANCE),
        diel("smooth 1.5 radiance", 0.0, 1.5, RADIANCE).energy(Energy::Radiance),
        diel("r0.3 1.5", 0.3, 1.5, IMPORTANCE).sharp(),
        diel("r0.5 1.5", 0.5, 1.5, IMPORTANCE),
        diel("r0.7 1.5", 0.7, 1.5, IMPORTANCE),
        diel("r0.3 1.33", 0.3, 1.33, IMPORTANCE).sharp(),
        diel("r0.7 1.33", 0.7, 1.33, IMPORTANCE),
        // Nearly index-matched: the transmitted lobe is nearly a delta whatever the roughness
        diel("r0.3 1.0001", 0.3, 1.0001, IMPORTANCE).sharp(),
        diel("r0.3 1.5 radiance", 0.3, 1.5, RADIANCE)
            .energy(Energy::Radiance)
            .sharp(),
    ];
    run_family("dielectric", &cases, 2, no_extra);
}

#[test]
fn principled_family() {
    let p = |name: &str| principled(name, RADIANCE);
    let cases = vec![
        p("principled default"),
        p("principled default one-sided").one_sided(),
        p("principled metallic r0.3")
            .c0([0.9, 0.6, 0.3])
            .s(0, 1.0)
            .s(1, 0.3)
            .sharp_grazing(),
        p("principled clearcoat")
            .c0(grey(0.8))
            .s(10, 1.0)
            .s(11, 0.5),
        p("principled sheen")
            .c0(grey(0.8))
            .s(5, 1.0)
            .s(6, 0.5)
            .energy(Energy::ExceedsLikeMitsuba),
        principled("principled spec_trans r0.5", IMPORTANCE)
            .c0(grey(1.0))
            .s(7, 1.0)
            .s(8, 1.5),
        principled("principled spec_trans r0.1", IMPORTANCE)
            .c0(grey(1.0))
            .s(1, 0.1)
            .s(7, 1.0)
            .s(8, 1.5)
            .sharp(),
        p("principled aniso0.8 met0.5 r0.4")
            .c0([0.8, 0.5, 0.2])
            .s(0, 0.5)
            .s(1, 0.4)
            .s(4, 0.8)
            .sharp_grazing(),
        p("principled white r0.2 spec1")
            .c0(grey(1.0))
            .s(1, 0.2)
            .s(2, 1.0)
            .energy(Energy::ExceedsLikeMitsuba)
            .sharp_grazing(),
    ];
    run_family("principled", &cases, 3, principled_vs_mitsuba);
}

#[test]
fn phong() {
    let ph = |name: &str, n: f32| {
        Case::new(name, MAT_PHONG, MATF_TWO_SIDED, RADIANCE)
            .c0(grey(0.5))
            .c1(grey(0.4))
            .s(0, n)
    };
    let cases = vec![
        ph("phong n1", 1.0),
        ph("phong n30", 30.0),
        ph("phong n1000", 1000.0).sharp(),
        ph("phong spec-only n30", 30.0).c0(grey(0.0)).c1(grey(1.0)),
        ph("phong spec-only n1000", 1000.0)
            .c0(grey(0.0))
            .c1(grey(1.0))
            .sharp(),
        ph("phong n30 one-sided", 30.0).one_sided(),
    ];
    run_family("phong", &cases, 4, no_extra);
}

/// Prints the principled albedos next to Mitsuba's, marks those above 1, and returns the
/// disagreements (and albedos above 1 where Mitsuba stays below).
fn principled_vs_mitsuba(cases: &[Case], stats: &[Vec<Stat>]) -> Vec<String> {
    let mut failures = Vec::new();
    println!(
        "\n{:<32} {:<9} {:>8} {:>8} {:>8} {:>8}",
        "principled vs Mitsuba", "wo", "albedo", "σ", "Mitsuba", "σ"
    );
    for (c, row) in cases.iter().zip(stats) {
        let reference = MITSUBA_PRINCIPLED.iter().find(|(n, _, _)| *n == c.name);
        assert!(reference.is_some(), "{}: no Mitsuba reference", c.name);
        let (_, values, sigmas) = reference.unwrap();
        for (wi, st) in row.iter().enumerate().take(4) {
            let (r, rs) = (values[wi], sigmas[wi]);
            if r.is_nan() {
                continue;
            }
            let exceeds = st.albedo > 1.0 + 3.0 * st.albedo_sigma;
            println!(
                "{:<32} {:<9} {:>8.4} {:>8.1e} {r:>8.4} {rs:>8.1e}{}",
                c.name,
                WO_NAMES[wi],
                st.albedo,
                st.albedo_sigma,
                if exceeds { "  > 1" } else { "" }
            );
            let tol = 4.0 * (st.albedo_sigma.powi(2) + rs * rs).sqrt() + MITSUBA_TOL;
            if (st.albedo - r).abs() > tol {
                failures.push(format!(
                    "{} @ {}: albedo {:.4} vs Mitsuba {r:.4} (tolerance {tol:.1e})",
                    c.name, WO_NAMES[wi], st.albedo
                ));
            }
            if exceeds && c.energy != Energy::ExceedsLikeMitsuba {
                failures.push(format!(
                    "{} @ {}: albedo {:.4} > 1",
                    c.name, WO_NAMES[wi], st.albedo
                ));
            }
        }
    }
    failures
}
