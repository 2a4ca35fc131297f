//! The one-line backend hint of `phyxel run` and `view`: when another built-in backend
//! would run the scene faster at the same accuracy, say so (and change nothing).
//!
//! The rule is the measured trade (docs/BACKENDS.md, docs/PERFORMANCE.md "Real time"):
//! an `mls-implicit` step costs about 50–100 `mls` steps, and backward Euler changes
//! only what moves fast (it damps vibration and impacts shorter than its step), so it
//! wins where `mls` needs more than [`STEP_RATIO`] of its steps per frame-rate step and
//! nothing moves at the start (the cantilever: 0.37 against 2.8 wall s per simulated s).
//! A scene whose bodies start moving (impacts to resolve) gets no hint.

use crate::World;
use crate::solver::DEFAULT_DT;

/// `mls` steps per `mls-implicit` step above which the implicit backend is faster.
pub const STEP_RATIO: f32 = 100.0;

/// The hint for `world` as built, or `None`: every moving body on `mls`, all at rest,
/// and `dt` below `DEFAULT_DT / STEP_RATIO`.
pub fn backend_hint(world: &World) -> Option<String> {
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
