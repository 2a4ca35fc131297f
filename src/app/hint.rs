//! The one-line backend hint of `phyxel run` and `view`: when another built-in backend
//! would run the scene faster at the same accuracy, say so (and change nothing).
//!
//! The rule is the measured trade (docs/BACKENDS.md, docs/PERFORMANCE.md "Real time"):
//! an `mls-implicit` step costs about 50–100 `mls` steps, and backward Euler changes
//! only what moves fast (it damps vibration and impacts shorter than its step), so it
//! wins where `mls` needs more than [`STEP_RATIO`] of its steps per frame-rate step and
//! nothing moves at the start (the cantilever: 0.37 against 2.8 wall s per simulated s).
//! A scene whose bodies start moving (impacts to resolve) gets no hint.
//!
//! The other way, `mls` wins for certain where its stable step (each body's
//! [`Dynamics::explicit_dt`](crate::Dynamics::explicit_dt)) is at least
//! 1/[`EXPLICIT_RATIO`] of `dt`: at most two of its steps per implicit step, each 10–100
//! times cheaper (`plastic-fracture` at dt = 3e-4 s: 0.09 against 0.80 wall s per
//! simulated s).
//! Between that and the frame-rate step the cost of a backward-Euler step decides, and
//! it varies too much for a rule: at 12–15 `mls` steps per implicit step
//! `falling-sphere` and `self-contact` run 3–7 times faster on `mls`, while at 8–19
//! `soft-on-plane` and `sphere-on-plane` run 1.6–2.2 times faster on `mls-implicit`
//! (docs/PERFORMANCE.md, "Real time"); those get no hint.

use crate::World;
use crate::solver::DEFAULT_DT;

/// `mls` steps per `mls-implicit` step above which the implicit backend is faster.
pub const STEP_RATIO: f32 = 100.0;

/// `mls` steps per implicit step at most for the hint to name `mls`.
pub const EXPLICIT_RATIO: f32 = 2.0;

/// The hint for `world` as built, or `None`: every moving body on `mls`, all at rest,
/// and `dt` below `DEFAULT_DT / STEP_RATIO`; or every moving body on `mls-implicit` and
/// their explicit bound above `dt / EXPLICIT_RATIO`.
pub fn backend_hint(world: &World) -> Option<String> {
    implicit_hint(world).or_else(|| explicit_hint(world))
}

fn explicit_hint(world: &World) -> Option<String> {
    let moving: Vec<_> = world.objects.iter().filter(|o| !o.is_static()).collect();
    if moving.is_empty() || moving.iter().any(|o| o.dynamics.name() != "mls-implicit") {
        return None;
    }
    let bound = moving
        .iter()
        .map(|o| o.dynamics.explicit_dt(&o.phyxels, &o.material))
        .try_fold(f32::INFINITY, |b, d| d.map(|d| b.min(d)))?;
    (bound * EXPLICIT_RATIO >= world.dt).then(|| {
        format!(
            "`--backend mls` is stable at about {bound:.2e} s here, at least half of dt \
             ({:.2e} s): with steps 10-100 times cheaper than backward Euler's it would run \
             this scene faster, and resolve what backward Euler damps (docs/BACKENDS.md)",
            world.dt
        )
    })
}

fn implicit_hint(world: &World) -> Option<String> {
    let moving: Vec<_> = world.objects.iter().filter(|o| !o.is_static()).collect();
    let all_mls = !moving.is_empty() && moving.iter().all(|o| o.dynamics.name() == "mls");
    let at_rest = moving.iter().all(|o| {
        let v = &o.phyxels.vel;
        (0..o.phyxels.len()).all(|j| v.get(j) == glam::Vec3::ZERO)
    });
    (all_mls && at_rest && world.dt * STEP_RATIO < DEFAULT_DT).then(|| {
        format!(
            "every body starts at rest and dt is {:.2e} s: `--backend mls-implicit` would step \
             this scene at 1/120 s, {:.0} times fewer steps, with the same static result \
             (backward Euler damps fast vibration; docs/BACKENDS.md)",
            world.dt,
            DEFAULT_DT / world.dt
        )
    })
}
