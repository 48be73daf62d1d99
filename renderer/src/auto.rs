//! `auto`: the integrator chosen for the scene by a short pilot (issue 14 item 4). Each unbiased
//! integrator of the registry that can see the scene's lights (not pt with delta lights) renders a few percent of the budget; its relMSE estimated without
//! a reference (metrics/estimate.rs) times its render time is its cost (for an unbiased
//! estimator relMSE falls as 1/time, so error × time is what it pays for a given error), and the
//! cheapest continues from its pilot's samples to the budget. The choice and every pilot's
//! figures go into the render's stats (`auto`).
//!
//! Limits: the pilot's few samples make every estimate noisy (fireflies not yet seen make it
//! low); kernel compilation is not counted. (bdpt's light-tracing splats are split by parity
//! like its camera samples, so its estimate sees them: render/halves.rs.)

use std::sync::Arc;

use crate::film::Image;
use crate::gpu::GpuContext;
use crate::integrators::{IntegratorOptions, INTEGRATORS};
use crate::prepare::PreparedScene;
use crate::render::{render, Budget, RenderError, RenderSession, RenderStats};
pub use crate::render::{AutoChoice, Pilot};

/// The name a render or a job asks for `auto` by (not an integrator of the registry).
pub const AUTO: &str = "auto";

/// One line on `auto`, for lists of integrators (`GET /api/integrators`, the web form).
pub const AUTO_SUMMARY: &str = "Chosen by a pilot: each unbiased integrator renders a few \
    percent of the budget, the one with the least estimated error × time renders the rest.";

/// The integrators `auto` may choose (the registry's unbiased ones; pt is left out on scenes
/// with delta lights, when the pilot runs).
pub fn candidates() -> Vec<&'static str> {
    INTEGRATORS
        .iter()
        .filter(|i| i.unbiased)
        .map(|i| i.name)
        .collect()
}

/// The share of the budget all pilots take together.
pub const PILOT_SHARE: f64 = 0.05;

/// Fewest samples per pixel of a pilot (the estimate needs samples in both halves).
pub const PILOT_MIN_SPP: u32 = 8;

/// The pilot's outcome: the winner's session (holding its pilot's samples), its options, the
/// choice with every pilot's figures, and what the budget has left for the winner.
pub struct Piloted {
    pub session: RenderSession,
    pub options: IntegratorOptions,
    pub choice: AutoChoice,
    /// The budget less the other pilots' time (a time budget; an spp budget is unchanged: the
    /// winner's pilot samples count towards it).
    pub rest: Budget,
}

/// Renders with the integrator the pilot finds cheapest (see the module docs) to `budget`
/// (pilots included), with `max_depth` for every integrator when given; the stats carry the
/// choice (`RenderStats::auto`).
pub fn render_auto(
    prepared: &PreparedScene,
    ctx: &Arc<GpuContext>,
    seed: u64,
    max_depth: Option<i32>,
    budget: Budget,
) -> Result<(Image, RenderStats), RenderError> {
    let mut p = pilot(prepared, ctx, seed, max_depth, budget)?;
    let (image, mut stats) = render(&mut p.session, p.rest)?;
    stats.auto = Some(p.choice);
    Ok((image, stats))
}

/// Runs the pilots for `budget` (steps 1–3 of the module docs) and returns the winner's
/// session, ready to continue to [`Piloted::rest`] (the server's jobs drive it pass by pass).
pub fn pilot(
    prepared: &PreparedScene,
    ctx: &Arc<GpuContext>,
    seed: u64,
    max_depth: Option<i32>,
    budget: Budget,
) -> Result<Piloted, RenderError> {
    // Unbiased for this scene: pt is left out where the scene has delta lights (it cannot see
    // them, so its image is dark and its estimate small, not good).
    let delta = prepared.compiled.features.delta_lights;
    let candidates: Vec<&'static str> = INTEGRATORS
        .iter()
        .filter(|i| i.unbiased && (i.delta_lights || !delta))
        .map(|i| i.name)
        .collect();
    let n = candidates.len().max(1) as f64;
    // Step 1: each pilot's share: a time, or a sample count (then each integrator's own time
    // is measured).
    let pilot_budget = match budget {
        Budget::Time(t) => Budget::Time(t * PILOT_SHARE / n),
        Budget::Spp(s) => Budget::Spp(((s as f64 * PILOT_SHARE / n) as u32).max(PILOT_MIN_SPP)),
    };
    // Step 2: the pilots; each session is kept to continue the winner.
    let mut pilots = Vec::new();
    let mut sessions = Vec::new();
    let mut all_options = Vec::new();
    for name in candidates {
        let mut options = IntegratorOptions::from_name(name)
            .ok_or_else(|| RenderError::Invalid(format!("no integrator {name}")))?;
        if let Some(d) = max_depth {
            options.set_max_depth(d);
        }
        all_options.push(options);
        let mut session = prepared.session(ctx, &options, seed)?;
        let (_, mut stats) = render(&mut session, pilot_budget)?;
        // A time share too short for the estimate (a slow integrator on a large film) is
        // topped up to the fewest samples it needs; the cost counts the whole time.
        if stats.spp < PILOT_MIN_SPP {
            stats = render(&mut session, Budget::Spp(PILOT_MIN_SPP))?.1;
        }
        let cost = stats
            .rel_mse_estimate
            .map(|e| e * stats.time_s)
            .filter(|c| c.is_finite());
        pilots.push(Pilot {
            integrator: name,
            spp: stats.spp,
            time_s: stats.time_s,
            rel_mse_estimate: stats.rel_mse_estimate,
            cost,
        });
        sessions.push(session);
    }
    // Step 3: the cheapest (an integrator without an estimate only if none has one).
    let best = (0..pilots.len())
        .min_by(|&a, &b| {
            let key = |i: usize| pilots[i].cost.unwrap_or(f64::INFINITY);
            key(a).total_cmp(&key(b))
        })
        .ok_or_else(|| RenderError::Invalid("no unbiased integrator to choose from".into()))?;
    let spent_elsewhere: f64 = pilots
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != best)
        .map(|(_, p)| p.time_s)
        .sum();
    // Step 4: the winner continues from its pilot's samples to the budget (a time budget less
    // the other pilots' time).
    let session = sessions.swap_remove(best);
    drop(sessions);
    let rest = match budget {
        Budget::Time(t) => Budget::Time((t - spent_elsewhere).max(0.0)),
        b => b,
    };
    Ok(Piloted {
        session,
        options: all_options[best],
        choice: AutoChoice {
            choice: pilots[best].integrator,
            pilots,
        },
        rest,
    })
}
