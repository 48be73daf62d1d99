//! Statistics shared by the renderer's GPU tests: a seeded uniform source and Pearson's
//! chi-square test with its p-value.
#![allow(dead_code)] // each test binary uses its own part

use std::f64::consts::PI;

/// SplitMix64 (Steele et al. 2014): the host-side source of the uniforms fed to the warps.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// A uniform in [0, 1) with 24 bits, exactly representable in f32 (as the GPU RNG makes).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / 16_777_216.0)
    }
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9; ~1e-15 relative).
pub fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma Q(a, x) (Numerical Recipes §6.2: series below a + 1,
/// Lentz's continued fraction above).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let ln_prefactor = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        let (mut ap, mut sum, mut del) = (a, 1.0 / a, 1.0 / a);
        for _ in 0..10_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * ln_prefactor.exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        ln_prefactor.exp() * h
    }
}

/// Outcome of a chi-square test.
pub struct Chi2 {
    pub chi2: f64,
    pub dof: usize,
    pub p: f64,
    /// Points in bins whose expected count is 0 (each is a hard failure).
    pub impossible: u64,
}

/// Pearson's chi-square of `observed` counts against `prob` (bin probabilities, summing to ~1)
/// for `n` points; bins expected below 5 are pooled into one (Mitsuba 3's `ChiSquareTest`).
pub fn chi_square(observed: &[u64], prob: &[f64], n: u64) -> Chi2 {
    let mut order: Vec<usize> = (0..observed.len()).collect();
    order.sort_by(|&i, &j| prob[i].total_cmp(&prob[j]));
    let (mut chi2, mut dof, mut impossible) = (0.0, 0usize, 0u64);
    let (mut pool_obs, mut pool_exp) = (0.0f64, 0.0f64);
    for &i in &order {
        let expected = prob[i] * n as f64;
        let obs = observed[i] as f64;
        if expected <= 0.0 {
            impossible += observed[i];
        } else if expected < 5.0 {
            pool_obs += obs;
            pool_exp += expected;
        } else {
            chi2 += (obs - expected).powi(2) / expected;
            dof += 1;
        }
    }
    if pool_exp > 0.0 {
        chi2 += (pool_obs - pool_exp).powi(2) / pool_exp;
        dof += 1;
    }
    let dof = dof.saturating_sub(1).max(1);
    Chi2 {
        chi2,
        dof,
        p: gamma_q(dof as f64 / 2.0, chi2 / 2.0),
        impossible,
    }
}
