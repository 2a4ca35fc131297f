//! The run's guards: what the step relies on and the caller may have changed (checked
//! before each step), the first non-finite value (found during and after it), and `dt`
//! kept within the stable bound when the topology changes.

use super::World;
use super::record::{DT_FRACTION, DtChange};
use crate::body::object::Object;
use crate::spatial::broad_phase::Aabb;

/// Where the state first stopped being finite, found by the step's checks of every
/// moving object (surfel positions through the broad phase's boxes, which flag a
/// non-finite point for free; phyxel positions, velocities and forces at the end of the
/// step), so that a run can stop at once and say which object and which phase, and a
/// blown-up object takes no part in contact (its box overlaps nothing) instead of
/// carrying NaN into every object it touches.
#[derive(Clone, Debug, PartialEq)]
pub struct NonFinite {
    /// The step (counted from 1) in which it was found.
    pub step: u64,
    /// The object's id and name, and its backend's [`crate::Dynamics::name`].
    pub object_id: u32,
    pub object: String,
    pub backend: String,
    /// `"phyxel position"`, `"phyxel velocity"`, `"phyxel force"` or
    /// `"surfel position"`.
    pub quantity: &'static str,
    /// The first phyxel or surfel (by index) with a non-finite value.
    pub index: usize,
    /// Set when the values are finite but so far from the origin (this distance, m)
    /// that f32 rounds them to more than [`RANGE_RESOLUTION`] of the object's surfel
    /// spacing: its motion and contact are rounding (a body under a gravity of −1e30
    /// ended at −1e26 m, reported finite).
    pub out_of_range: Option<f32>,
}

/// Coarsest f32 resolution a moving object's surfels may reach during a run, as a
/// fraction of its surfel spacing ([`NonFinite`]'s `out_of_range`): a hundred times the
/// placement check's ([`crate::scene::POSITION_RESOLUTION`]), which leaves a placed
/// body room to move. At the default 5 mm surfels that is some 4 km from the origin.
pub const RANGE_RESOLUTION: f32 = 0.1;

impl NonFinite {
    /// The phase that wrote the value. The checks run in the order the step writes
    /// (phyxels before surfels, forces last), and every value was finite at the last
    /// check, so the first non-finite one comes from the phase that wrote it.
    pub fn source(&self) -> &'static str {
        match self.quantity {
            "phyxel force" => "the contact forces",
            "surfel position" => "the surfel advection",
            _ => "the dynamics step",
        }
    }

    /// The object's first non-finite value, in the order the step writes them.
    pub(super) fn find(o: &Object, step: u64, surfels: bool) -> Option<Self> {
        let p = &o.phyxels;
        let columns = [
            (&p.pos, "phyxel position"),
            (&p.vel, "phyxel velocity"),
            (&p.force, "phyxel force"),
            (&o.surfels.pos, "surfel position"),
        ];
        let (index, quantity) = columns[..if surfels { 4 } else { 3 }]
            .iter()
            .find_map(|&(c, q)| c.first_non_finite().map(|i| (i, q)))?;
        Some(Self {
            step,
            object_id: o.id,
            object: o.name.clone(),
            backend: o.dynamics.name().to_string(),
            quantity,
            index,
            out_of_range: None,
        })
    }

    /// The object's surface box `surface` beyond f32's resolution of its surfel spacing,
    /// as [`NonFinite::out_of_range`].
    pub(super) fn beyond_range(o: &Object, surface: &Aabb, step: u64) -> Option<Self> {
        let reach = surface.min.abs().max(surface.max.abs()).max_element();
        // (An infinite reach is the non-finite check's.)
        (reach.is_finite() && reach * f32::EPSILON > RANGE_RESOLUTION * o.surfel_spacing).then(
            || Self {
                step,
                object_id: o.id,
                object: o.name.clone(),
                backend: o.dynamics.name().to_string(),
                quantity: "surfel position",
                index: 0,
                out_of_range: Some(reach),
            },
        )
    }
}

impl std::fmt::Display for NonFinite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(reach) = self.out_of_range {
            return write!(
                f,
                "step {}: object '{}' (id {}, backend {}): its surface reached {reach:.2e} m \
                 from the origin, where f32 rounds positions to more than {RANGE_RESOLUTION} of \
                 its surfel spacing: its motion there is rounding (a blow-up, or loads, gravity \
                 or velocities far out of scale)",
                self.step, self.object, self.object_id, self.backend,
            );
        }
        let (kind, what) = self
            .quantity
            .split_once(' ')
            .unwrap_or(("point", self.quantity));
        write!(
            f,
            "step {}: object '{}' (id {}, backend {}): {kind} {} {what} became non-finite in {}",
            self.step,
            self.object,
            self.object_id,
            self.backend,
            self.index,
            self.source()
        )
    }
}

impl World {
    /// What the step relies on and the caller may have changed (the fields are public):
    /// a finite dt > 0 and gravity, distinct object ids below `u32::MAX` (the caches and
    /// fragments key on them), valid materials, columns of the counts each object was
    /// built with, and phyxel masses, volumes, spacings and radii finite and > 0
    /// ([`Object::check_counts`]). A few comparisons per object, and one pass over four
    /// phyxel columns (15 µs for the 1M scene's 40k phyxels, under 0.1% of its step).
    pub(super) fn check_inputs(&mut self) {
        assert!(
            self.dt.is_finite() && self.dt > 0.0,
            "World::dt = {}: must be a finite number > 0",
            self.dt
        );
        assert!(
            self.gravity.is_finite(),
            "World::gravity = {}: must be finite",
            self.gravity
        );
        for (k, o) in self.objects.iter().enumerate() {
            if let Err(e) = o.check_counts() {
                panic!("World::step: {e}");
            }
            if let Err(e) = o.material.validate() {
                panic!(
                    "World::step: object '{}' (id {}): invalid material: {e}",
                    o.name, o.id
                );
            }
            assert!(
                o.id != u32::MAX,
                "World::step: object '{}': id u32::MAX is reserved",
                o.name
            );
            if let Some(other) = self.objects[..k].iter().find(|p| p.id == o.id) {
                panic!(
                    "World::step: objects '{}' and '{}' share the id {}: ids must be distinct",
                    other.name, o.name, o.id
                );
            }
            // Objects added since `new`: fragments' ids stay above theirs.
            self.next_id = self.next_id.max(o.id + 1);
        }
    }

    /// Lowers `dt` to [`DT_FRACTION`] of the stable bound if it has fallen below `dt`
    /// ([`World::keep_stable`]). A bound that is not a number > 0 is left to the
    /// finiteness checks.
    pub(super) fn keep_dt_stable(&mut self) {
        let (bound, limiter) = self.stable_dt();
        let Some(o) = limiter.and_then(|id| self.object(id)) else {
            return;
        };
        if !(bound > 0.0 && bound < self.dt) {
            return;
        }
        let change = DtChange {
            step: self.steps,
            from: self.dt,
            to: DT_FRACTION * bound,
            bound,
            object: o.name.clone(),
            object_id: o.id,
        };
        self.dt = change.to;
        self.record.dt_changes.push(change);
    }

    /// The first moving object's first non-finite phyxel value (the end-of-step
    /// check; surfels are checked by the broad phase's boxes). A pass over 9 floats per
    /// phyxel: about 0.1% of a step of the 1M scene.
    pub(super) fn find_non_finite(&self) -> Option<NonFinite> {
        self.objects
            .iter()
            .filter(|o| !o.is_static())
            .find_map(|o| NonFinite::find(o, self.steps, false))
    }
}

/// Largest relative travel in one step of two nearby bodies, as a share of the thinner
/// one's thickness, that the world lets pass without a warning. A contact surfel must be
/// found inside the other body and pushed out over several steps; a pair that closes by a
/// quarter of a body's thickness per step can cross it before the penalty builds up
/// (two spheres 0.2 m across closing at 2 m/s passed through each other at dt = 0.05 s,
/// 0.1 m per step). Scenes at their default dt close by about 1e-3 of it.
pub const CROSSING_SHARE: f32 = 0.25;

/// A pair that closed by more than [`CROSSING_SHARE`] of the thinner body's thickness
/// in one step: the first one found, as a warning naming the step, the bodies and the
/// figures.
pub(super) fn crossing_warning(
    objects: &[Object],
    previous: &[Aabb],
    current: &[Aabb],
    step: u64,
    dt: f32,
) -> Option<String> {
    let travel = |k: usize| -> f32 {
        let (a, b) = (previous[k], current[k]);
        if objects[k].is_static() || a.is_non_finite() || a.min.x > a.max.x {
            return 0.0;
        }
        (b.min - a.min)
            .abs()
            .max((b.max - a.max).abs())
            .max_element()
    };
    let thickness = |k: usize| (current[k].max - current[k].min).min_element().max(0.0);
    let thinnest = (0..objects.len())
        .map(thickness)
        .fold(f32::INFINITY, f32::min);
    for i in 0..objects.len() {
        let ti = travel(i);
        // Pruned: no pair with `i` can exceed the share unless `i` or its partner moved
        // far; the partner's own turn covers the second case.
        if ti.is_nan() || ti <= 0.5 * CROSSING_SHARE * thinnest {
            continue;
        }
        for j in (0..objects.len()).filter(|&j| j != i) {
            let closing = ti + travel(j);
            let gap = (current[j].min - current[i].max)
                .max(current[i].min - current[j].max)
                .max_element();
            let thinner = thickness(i).min(thickness(j));
            if gap <= closing && closing > CROSSING_SHARE * thinner {
                return Some(format!(
                    "step {step}: '{}' and '{}' closed by {closing:.3e} m in one step of \
                     dt = {dt:.3e} s, more than {CROSSING_SHARE} of the thinner one's \
                     thickness ({thinner:.3e} m): contact can be crossed in a step without \
                     being felt (bodies pass through each other); lower dt (--dt)",
                    objects[i].name, objects[j].name
                ));
            }
        }
    }
    None
}
