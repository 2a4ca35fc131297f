//! The record of a run: statistics that the step accumulates and `run --json` reports,
//! the dt changes it made, and the energy it measures.

use super::phase::PhaseTimes;
use crate::body::fracture::SplitEvent;

/// Statistics of the run so far (all objects, all steps).
#[derive(Clone, Debug, Default)]
pub struct RunRecord {
    /// Wall time and work per phase, summed over the run.
    pub times: PhaseTimes,
    /// Largest signed penetration depth of a colliding force carrier over the run (m).
    pub max_penetration: f32,
    /// Contact surfels whose friction force was evaluated, summed over the run
    /// (zero when every pair has μ = 0: no friction work).
    pub friction_work: u64,
    /// Every split so far, in order (the run summary's `fractures`).
    pub splits: Vec<SplitEvent>,
    /// Rest configurations renewed by plastic flow so far (all objects).
    pub rest_renewals: u64,
    /// Steps whose contact phases ran again because a surface query reached surfels
    /// that lazy advection had left stale (`World::lazy_advection`; speed only).
    pub lazy_reruns: u64,
    /// Every lowering of `dt` so far, in order.
    pub dt_changes: Vec<DtChange>,
    /// What the world's builder found suspect but legal (`Scene::build`: a body too
    /// coarsely sampled for its mass, [`crate::scene::MASS_WARNING`]; two bodies whose
    /// start velocities close them faster than the P-wave speed); `run` prints them.
    pub warnings: Vec<String>,
    /// Each pair's contact over the run so far.
    pub contacts: ContactHistory,
}

/// One pair's contact over a run (`run --json` key `contacts`): the pair's
/// [`crate::contact::PatchTotals`] gathered over the steps in which it touched.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PairHistory {
    /// The objects' ids and names.
    pub a: u32,
    pub b: u32,
    pub a_name: String,
    pub b_name: String,
    /// Steps whose contact phase found the pair touching.
    pub steps: u64,
    /// Simulated time at the end of the first and the last of them (s).
    pub first_time: f64,
    pub last_time: f64,
    /// The contact force on a times each step's dt, summed over those steps (N·s): the
    /// momentum the contact gave a (b took the opposite).
    pub impulse: [f64; 3],
    /// Largest and mean (over `steps`) normal load (N, `PatchTotals::normal_force`).
    pub peak_normal_force: f64,
    pub mean_normal_force: f64,
    /// Largest `PatchTotals::peak_pressure` (Pa), `max_penetration` (m) and `area`
    /// (m²) over those steps.
    pub peak_pressure: f64,
    pub max_penetration: f64,
    pub max_area: f64,
}

/// [`PairHistory`] per pair, keyed by object ids (indices shift when an object
/// fractures). Allocates only when a pair touches for the first time.
#[derive(Clone, Debug, Default)]
pub struct ContactHistory(std::collections::BTreeMap<(u32, u32), PairHistory>);

impl ContactHistory {
    /// Adds the step that ended at `time` with `patches` between `objects`.
    pub fn add(
        &mut self,
        objects: &[crate::Object],
        patches: &[crate::contact::ContactPatch],
        time: f64,
        dt: f32,
    ) {
        for patch in patches.iter().filter(|p| !p.surfels.is_empty()) {
            // No torque is kept: any centre does.
            let (a, b) = (&objects[patch.a], &objects[patch.b]);
            let t = crate::contact::PatchTotals::of(patch, [a.id, b.id], glam::DVec3::ZERO);
            let h = self.0.entry((a.id, b.id)).or_insert_with(|| PairHistory {
                a: a.id,
                b: b.id,
                a_name: a.name.clone(),
                b_name: b.name.clone(),
                steps: 0,
                first_time: time,
                last_time: time,
                impulse: [0.0; 3],
                peak_normal_force: 0.0,
                mean_normal_force: 0.0,
                peak_pressure: 0.0,
                max_penetration: 0.0,
                max_area: 0.0,
            });
            h.steps += 1;
            h.last_time = time;
            for k in 0..3 {
                h.impulse[k] += t.force[k] * dt as f64;
            }
            h.peak_normal_force = h.peak_normal_force.max(t.normal_force);
            h.mean_normal_force += (t.normal_force - h.mean_normal_force) / h.steps as f64;
            h.peak_pressure = h.peak_pressure.max(t.peak_pressure);
            h.max_penetration = h.max_penetration.max(t.max_penetration);
            h.max_area = h.max_area.max(t.area);
        }
    }

    /// Every pair that touched, in object-id order.
    pub fn pairs(&self) -> Vec<PairHistory> {
        self.0.values().cloned().collect()
    }
}

/// `dt` lowered after a change of topology ([`World::keep_stable`](super::World::keep_stable)): a rest shape
/// renewed by plastic flow, or a fragment, can be much stiffer than the body the run
/// started with (a compressed, torn MLS rest stencil raises `ω_max` many times), and an
/// explicit step above its bound gains energy without bound, often with no NaN.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DtChange {
    /// Step after which `dt` changed (1-based, as [`World::steps`](super::World::steps)).
    pub step: u64,
    /// The old and the new `dt` (s).
    pub from: f32,
    pub to: f32,
    /// The new stable bound (s), and the object that sets it.
    pub bound: f32,
    pub object: String,
    pub object_id: u32,
}

impl std::fmt::Display for DtChange {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "step {}: dt lowered from {:.3e} to {:.3e} s: the stable bound of object '{}' \
             (id {}) fell to {:.3e} s after a rest renewal or a fracture",
            self.step, self.from, self.to, self.object, self.object_id, self.bound
        )
    }
}

/// Mechanical energy of the moving objects (J): see [`World::energy`](super::World::energy).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Energy {
    pub kinetic: f64,
    pub elastic: f64,
    /// Gravitational, `−Σ m g·x` (zero at the origin).
    pub potential: f64,
    /// Stored in the contact penalty springs at the last contact phase
    /// ([`World::contact_energy`](super::World::contact_energy); 0 before the first step).
    pub contact: f64,
}

impl Energy {
    /// Kinetic plus elastic plus potential plus contact.
    pub fn total(&self) -> f64 {
        self.kinetic + self.elastic + self.potential + self.contact
    }
}

/// Fraction of the stable bound `dt` is lowered to ([`World::keep_stable`](super::World::keep_stable)): the
/// default dt's margin (`Scene::build`).
pub const DT_FRACTION: f32 = 0.9;

/// Largest default `dt` (s): when no object has a stable bound, and when the bound is
/// longer. Stability alone does not resolve motion: a material of 1e-38 Pa had a bound
/// of 2·10¹⁸ s, and its first steps under gravity fell past f32's range. No built-in
/// scene's bound reaches it (the softest, `soft-on-plane`, runs at 0.95 ms).
pub const MAX_DEFAULT_DT: f32 = 1e-3;

/// Moved to [`crate::solver::DEFAULT_DT`].
#[deprecated(note = "use phyxel::solver::DEFAULT_DT")]
pub const IMPLICIT_DEFAULT_DT: f32 = crate::solver::DEFAULT_DT;
