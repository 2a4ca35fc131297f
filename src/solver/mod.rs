//! The implicit solve: backward Euler over islands of implicit bodies, with the contact
//! springs between them in the system.
//!
//! A backend joins it by giving the operators of its step
//! ([`crate::dynamics::Dynamics::implicit`], [`crate::dynamics::implicit::Implicit`]).
//! After each step's contact forces the patches between implicit bodies (or between one
//! and a static object) become [`ContactSprings`] ([`springs`]); the next step finds the
//! [`Islands`] they join and runs Newton's method with preconditioned conjugate gradients
//! over each island at once ([`solve`]), the springs' linearised penalty, dashpot and
//! friction rows beside the members' tangents ([`active`]). A stiff contact then no
//! longer limits dt, and the springs' forces on the two sides are equal and opposite at
//! every iterate, so an island's momentum changes only by the external impulse and the
//! solver's final residual. [`skyline`] is the factor backends precondition with, and
//! [`DEFAULT_DT`] the step a scene of implicit bodies runs at.
//!
//! [`Solver`] is the world's entry: its two calls are the whole of what the step does
//! with the solve.

pub mod active;
mod islands;
mod newton;
pub mod skyline;
pub mod springs;
mod transfer;

pub use islands::Islands;
pub use newton::{DEFERRED_CG, Member, ROUNDING_FACTOR, SolveScratch, solve};
pub use springs::{ContactSpring, ContactSprings, SpringSide};

use crate::body::object::Object;
use crate::contact::ContactPatch;
use crate::contact::detect::PairDetection;
use crate::contact::stick::StickMemory;
use crate::dynamics::StepContext;
use crate::par;
use crate::spatial::grid::Grid;
use glam::Vec3;
use rayon::prelude::*;

/// Default `dt` (s) of a scene whose moving objects are all implicit (no stable bound,
/// contacts in the solve): a frame-rate step, two per frame at 60 Hz. Backward Euler
/// keeps it stable; what it costs is accuracy (damping and stretched periods of fast
/// modes, and impacts shorter than a step, docs/BACKENDS.md), which `--dt` trades back.
pub const DEFAULT_DT: f32 = 1.0 / 120.0;

/// The solve's state between steps: the islands, each island's buffers (no allocation
/// in the steady step) and the contacts' friction anchors ([`crate::contact::stick`]). Dropped, it is
/// rebuilt, and the anchors start again from zero.
#[derive(Default)]
pub struct Solver {
    islands: Islands,
    /// Per object, the buffers of the island it leads.
    scratch: Vec<SolveScratch>,
    /// Phyxel queries of the springs.
    near: Vec<(usize, f32)>,
    knn: Vec<(usize, f32)>,
    /// The springs of the step before, kept for their buffers.
    last_springs: ContactSprings,
    /// The friction anchors of the last solves' springs.
    stick: StickMemory,
}

impl Solver {
    /// Steps every moving object of `objects` by `dt` under `gravity`, its load at time
    /// `time` (s) and `phyxels.force`: explicit bodies by their backend's step, implicit
    /// ones by islands joined by `springs` (the last step's), each island in one solve.
    /// Bodies alone in their island and explicit ones run in parallel, then the islands
    /// of several bodies in parallel. `after` runs on each object once it has stepped.
    pub fn step(
        &mut self,
        objects: &mut [Object],
        springs: &ContactSprings,
        dt: f32,
        gravity: Vec3,
        time: f32,
        after: impl Fn(&Object) + Sync,
    ) {
        for o in objects.iter_mut() {
            o.refresh_implicit();
        }
        let n = objects.len();
        self.islands.find(objects, springs);
        self.scratch.resize_with(n, Default::default);
        for scratch in &mut self.scratch {
            scratch.forget_springs();
        }
        let islands = &self.islands;
        let alone = |k: usize, o: &Object| !o.is_frozen() && !islands.shared(k);
        let busy = objects
            .iter()
            .enumerate()
            .filter(|&(k, o)| alone(k, o))
            .count();
        let grain = par::grain_of(objects.len(), busy);
        // Bodies stepping side by side split their own loops finely; a body stepping
        // alone keeps its loops whole below twice `POINT_TASK`.
        let task = if busy > 1 {
            par::SHARED_POINT_TASK
        } else {
            par::POINT_TASK
        };
        objects
            .par_iter_mut()
            .zip(self.scratch.par_iter_mut())
            .with_min_len(grain)
            .enumerate()
            .filter(|(k, (o, _))| alone(*k, o))
            .for_each(|(k, (o, scratch))| {
                par::with_point_task(task, || {
                    o.apply_load(time);
                    let Object {
                        dynamics,
                        phyxels,
                        material,
                        ..
                    } = o;
                    match dynamics.implicit().filter(|_| islands.alone(k)) {
                        Some(dynamics) => {
                            let mut members = [Member {
                                object: k,
                                dynamics,
                                phyxels,
                                material,
                            }];
                            solve(&mut members, springs, dt, gravity, scratch);
                        }
                        None => {
                            let ctx = StepContext::new(dt, gravity, material);
                            dynamics.step(phyxels, &ctx);
                        }
                    }
                    after(o);
                })
            });
        if islands.any_shared() {
            self.solve_shared(objects, springs, dt, gravity, time, &after);
        }
        self.deliver_reactions(objects, springs);
        self.keep_sticks(springs, dt);
    }

    /// The anchors of this step's solves become the memory the next springs read.
    fn keep_sticks(&mut self, springs: &ContactSprings, dt: f32) {
        for (k, scratch) in self.scratch.iter().enumerate() {
            if self.islands.root(k) != Some(k) {
                continue;
            }
            for (index, stick) in scratch.sticks() {
                if let Some(key) = springs.springs[index].key.filter(|_| stick != Vec3::ZERO) {
                    self.stick.push(key, stick);
                }
            }
        }
        self.stick.commit(dt);
    }

    /// The islands of several bodies, in parallel (each solve is parallel inside, over
    /// its members).
    fn solve_shared(
        &mut self,
        objects: &mut [Object],
        springs: &ContactSprings,
        dt: f32,
        gravity: Vec3,
        time: f32,
        after: &(impl Fn(&Object) + Sync),
    ) {
        let islands = &self.islands;
        // Each island's members under its root (an object index: its buffers' too).
        let mut groups: Vec<Vec<Member<'_>>> = (0..objects.len()).map(|_| Vec::new()).collect();
        for (k, o) in objects.iter_mut().enumerate() {
            if !islands.shared(k) || o.is_asleep() {
                continue;
            }
            let r = islands.root(k).expect("a shared body is in an island");
            o.apply_load(time);
            let Object {
                dynamics,
                phyxels,
                material,
                ..
            } = o;
            let dynamics = dynamics
                .implicit()
                .expect("Solver::step: a backend's implicit() changed within the step");
            groups[r].push(Member {
                object: k,
                dynamics,
                phyxels,
                material,
            });
        }
        let grain = par::grain(groups.iter().map(|g| !g.is_empty()));
        self.scratch
            .par_iter_mut()
            .zip(groups.par_iter_mut())
            .with_min_len(grain)
            .filter(|(_, group)| !group.is_empty())
            .for_each(|(scratch, group)| {
                solve(group, springs, dt, gravity, scratch);
            });
        drop(groups);
        for (k, o) in objects.iter().enumerate() {
            if islands.shared(k) && !o.is_asleep() {
                after(o);
            }
        }
    }

    /// A tool (a prescribed side b) receives its springs' forces of this step's solves in
    /// `phyxels.force`, spread as the springs read it: its next step sums them into its
    /// reaction, as it does the forces the pipeline distributes.
    fn deliver_reactions(&self, objects: &mut [Object], springs: &ContactSprings) {
        for (k, scratch) in self.scratch.iter().enumerate() {
            if self.islands.root(k) != Some(k) {
                continue;
            }
            for (index, f) in scratch.given_reactions() {
                let sp = &springs.springs[index];
                if let (Some(b), Some(_)) = (sp.b, sp.given) {
                    let tool = &mut objects[b.object as usize].phyxels;
                    let (pos, force) = (&tool.pos, &mut tool.force);
                    springs.spread(&b, f, |j| pos.get(j), |j, fj| force.add(j, fj));
                }
            }
        }
    }

    /// Renews `springs` from this step's `patches`: those of pairs whose contact joins a
    /// solve ([`Object::contact_in_solve`]), the springs of the last step whose pair
    /// has just parted ([`springs::keep_parted`]), and the gaps found within the pairs'
    /// margins in `detections` ([`springs::speculate`]). `grids[k]`: object k's phyxel
    /// grid, built this step for its pairs.
    #[allow(clippy::too_many_arguments)]
    pub fn renew_springs(
        &mut self,
        springs: &mut ContactSprings,
        patches: &[ContactPatch],
        detections: &[PairDetection],
        objects: &[Object],
        grids: &[Option<Grid>],
        dt: f32,
    ) {
        let last = std::mem::take(springs);
        *springs = std::mem::take(&mut self.last_springs);
        springs.clear();
        if objects.iter().any(|o| !o.is_static() && o.is_implicit()) {
            let max_gap = objects
                .iter()
                .filter(|o| !o.is_static())
                .map(|o| o.phyxel_spacing)
                .fold(0.0f32, f32::max);
            // (`last` is empty unless it was built on this object list: the world drops
            // it otherwise.)
            springs::keep_parted(&last, patches, objects, dt, max_gap, springs);
            let parted = springs.springs.len();
            springs::build(
                patches,
                objects,
                grids,
                &self.stick,
                dt,
                springs,
                &mut self.near,
                &mut self.knn,
            );
            springs::speculate(
                detections,
                objects,
                grids,
                dt,
                parted,
                springs,
                &mut self.near,
                &mut self.knn,
            );
        }
        self.last_springs = last;
    }
}

#[cfg(test)]
mod tests {
    /// The friction anchors outlive a contact for one default step: at it, explicit and
    /// implicit stepping remember the same contacts (`contact::stick::GRACE`).
    #[test]
    fn stick_grace_is_the_default_step() {
        assert_eq!(crate::contact::stick::GRACE, super::DEFAULT_DT);
    }
}
