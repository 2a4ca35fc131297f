//! What a contact did, for users: each contact surfel's state and each pair's totals at
//! the last contact phase ([`crate::world::ContactState::patches`]), as plain serialisable values.
//!
//! The forces are the pipeline's (paper eqs. 3–7) at the positions of the step's end,
//! which act over the next step. A pair in an implicit solve (`Object::contact_in_solve`)
//! applies them as the start of its springs: its solve changes them over the step.

use super::{ContactPatch, ContactSurfel};
use glam::{DVec3, Vec3};
use serde::Serialize;

/// One contact surfel on the contact surface Φ.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ContactPoint {
    /// Position on Φ (m).
    pub position: [f32; 3],
    /// Unit normal of Φ, from object a into object b.
    pub normal: [f32; 3],
    /// Area of Φ it stands for (m²).
    pub area: f32,
    /// Overlap of the two original surfaces along the normal (m): `|d₁·n| + |d₂·n|`.
    pub penetration: f32,
    /// The force on object a (N) along the normal (penalty spring and dashpot) and
    /// across it (friction); object b takes the opposite.
    pub penalty_force: [f32; 3],
    pub friction_force: [f32; 3],
    /// Velocity of a's surface relative to b's across the normal (m/s).
    pub slip_velocity: [f32; 3],
}

impl ContactPoint {
    pub fn of(c: &ContactSurfel) -> Self {
        let n = c.normal;
        let along = |v: Vec3| n * v.dot(n);
        let penetration = (c.anchor_a - c.pos).dot(n).abs() + (c.anchor_b - c.pos).dot(n).abs();
        Self {
            position: c.pos.to_array(),
            normal: n.to_array(),
            area: c.area,
            penetration,
            penalty_force: along(c.force).to_array(),
            friction_force: (c.force - along(c.force)).to_array(),
            slip_velocity: (c.velocity - along(c.velocity)).to_array(),
        }
    }
}

/// The totals of one pair's contact patch.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PatchTotals {
    /// The pair's objects by id ([`crate::World::object`], [`crate::World::index_of`]):
    /// ids survive a fracture, which renumbers `World::objects`.
    pub a: u32,
    pub b: u32,
    /// Contact surfels carrying force.
    pub contact_surfels: usize,
    /// Total force on a (N); b takes the opposite.
    pub force: [f64; 3],
    /// Its normal part summed as magnitudes (N): the load the surfaces carry.
    pub normal_force: f64,
    /// Its friction part (N).
    pub friction_force: [f64; 3],
    /// The point the torque is taken about: midway between the two objects' centres of
    /// mass (m).
    pub centre: [f64; 3],
    /// Torque of the contact forces on a about `centre` (N·m).
    pub torque: [f64; 3],
    /// Area of Φ (m²).
    pub area: f64,
    /// Area-weighted centroid of Φ (m); `None` (JSON `null`) for a patch with no area
    /// (no contact surfel carries force): there is no point to give, and the origin
    /// would read as one.
    pub centroid: Option<[f64; 3]>,
    /// Largest normal pressure over the contact surfels (Pa).
    pub peak_pressure: f64,
    /// Largest overlap (m, [`ContactPoint::penetration`]).
    pub max_penetration: f64,
}

impl PatchTotals {
    /// The totals of `patch` between the objects of ids `a` and `b`, with torques about
    /// `centre`.
    pub fn of(patch: &ContactPatch, [a, b]: [u32; 2], centre: DVec3) -> Self {
        let (mut force, mut friction, mut torque) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
        let (mut normal, mut area, mut moment) = (0.0f64, 0.0f64, DVec3::ZERO);
        let (mut peak, mut deepest) = (0.0f64, 0.0f64);
        for c in &patch.surfels {
            let p = ContactPoint::of(c);
            let f = c.force.as_dvec3();
            let fn_ = DVec3::from(p.penalty_force.map(f64::from));
            force += f;
            friction += DVec3::from(p.friction_force.map(f64::from));
            torque += (c.pos.as_dvec3() - centre).cross(f);
            normal += fn_.length();
            let a = c.area as f64;
            area += a;
            moment += c.pos.as_dvec3() * a;
            if a > 0.0 {
                peak = peak.max(fn_.length() / a);
            }
            deepest = deepest.max(p.penetration as f64);
        }
        let centroid = (area > 0.0).then(|| (moment / area).to_array());
        Self {
            a,
            b,
            contact_surfels: patch.surfels.len(),
            force: force.to_array(),
            normal_force: normal,
            friction_force: friction.to_array(),
            centre: centre.to_array(),
            torque: torque.to_array(),
            area,
            centroid,
            peak_pressure: peak,
            max_penetration: deepest,
        }
    }
}
