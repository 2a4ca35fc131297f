//! The world and its step, read like the paper's `animate` (Keiser et al. 2004, §8).
//!
//! A [`World`] is the caller's settings and objects, the contact state of the last step,
//! the record of the run, and a private cache (grids, boxes, scratch) that can be
//! dropped and rebuilt at any time. The phases of a step live in `step.rs`, run in the
//! order of the one phase list [`Phase::ALL`]; the run's guards (inputs, non-finite
//! values, dt kept stable) in `guard.rs`.

mod cache;
mod guard;
mod in_order;
pub mod output;
pub mod phase;
mod preset;
mod record;
pub mod sleep;
mod step;

pub use guard::{NonFinite, RANGE_RESOLUTION};
pub use phase::{Phase, PhaseTimes};
pub use preset::Preset;
#[allow(deprecated)]
pub use record::{
    ContactHistory, DT_FRACTION, DtChange, Energy, IMPLICIT_DEFAULT_DT, MAX_DEFAULT_DT,
    PairHistory, RunRecord,
};

/// Where these lived in phyxel 0.1.
#[doc(hidden)]
pub use crate::contact::params::{
    CONTACT_LAYER_SPACINGS, DISTRIBUTION_SUPPORT, contact_layer, contact_params, contact_stable_dt,
};
pub use cache::{GRID_REGION_DEPTH_FACTOR, GRID_REGION_MARGIN};

use crate::body::object::Object;
use crate::contact::detect::PairDetection;
use crate::contact::params::compliance;
use crate::contact::stick::StickMemory;
use crate::contact::{ContactPatch, ContactSurfel};
use crate::solver::ContactSprings;
use crate::spatial::broad_phase::Pair;
use cache::StepCache;
use glam::Vec3;

/// All objects of a scene and the state of the run.
///
/// Four parts: what the caller sets (`objects`, `gravity`, `dt`, `keep_stable`,
/// `render_contacts`), the clock and the guard (`steps`, `time`, `non_finite`), the
/// contact state of the last step (`contact`: read it, the
/// step rewrites them), and the run's [`RunRecord`]. Privately it keeps the ids it
/// hands out and which object list the contact state indexes, and a cache of grids,
/// boxes and scratch: [`World::clear_cache`] drops the cache, and the next step
/// rebuilds it with the same results.
pub struct World {
    /// The objects. They may be reordered, added, removed or replaced between steps (ids
    /// must stay distinct: [`World::step`] checks); an object's columns keep the counts
    /// it was built with ([`Object::check_counts`]). A static object's box and grids are
    /// computed once for it: to move one, replace it by a new [`Object`] rather than
    /// writing its positions.
    pub objects: Vec<Object>,
    /// Gravitational acceleration (m/s²).
    pub gravity: Vec3,
    /// Time step (s).
    pub dt: f32,
    /// Keep `dt` within the stable bound when the topology changes: after a step that
    /// renewed a rest shape or split an object, the bound is recomputed and, if it fell
    /// below `dt`, `dt` is lowered to 90% of it ([`DtChange`]). Default `true`;
    /// `Scene::build` sets it to `false` with `allow_unstable`.
    pub keep_stable: bool,
    /// Build what the render surface `S \ C ∪ Φ` needs (only for output): resample the
    /// contact surfaces, and test every surfel for contact, not only the force carriers
    /// ([`FORCE_CARRIER_SPACING`](crate::body::object::FORCE_CARRIER_SPACING)), so that `C` holds all colliding surfels. The
    /// forces and the motion are the same either way.
    pub render_contacts: bool,
    /// Compute the contact forces on the resampled contact surface Φ, as the paper
    /// orders its steps (resampling, then forces), instead of on the contact surfels
    /// placed from the colliding ones (the default: `contact::resample` says why).
    /// Scene key `resampled_forces`; `preset = "paper"` sets it.
    pub resampled_forces: bool,
    /// Handle the contact pairs one after another, each against the surfaces
    /// `S ∖ C ∪ Φ` the pairs before it left, as the paper does (`in_order` module);
    /// false: independently and in parallel. Scene key `pairs_in_order`; `preset =
    /// "paper"` sets it.
    pub pairs_in_order: bool,
    /// Advect only the surfels a step reads: the blocks that outline each moving body's
    /// box and those near its contacts; the rest of its surfels stay where the last
    /// advection left them until [`World::sync_surfels`] (or a step with this off)
    /// moves them. The results are the same bits either way. Default `false`: every
    /// step leaves every surfel current. `phyxel run` and Python worlds turn it on and
    /// sync before the surfels are read (frames, the summary, the end of `World.step`).
    pub lazy_advection: bool,
    /// Let groups of bodies that have stayed still sleep until something moving touches
    /// them ([`sleep`]). Default `true`; scene key `sleep`.
    pub sleep: bool,
    /// The configuration the scene was built in (`Scene::build`; reported by
    /// `run --json`, it changes nothing in the step).
    pub preset: Preset,
    /// Steps taken so far.
    pub steps: u64,
    /// Simulated time (s): the sum of the steps' `dt` (which may change between steps);
    /// loads ramp up over it.
    pub time: f64,
    /// The first non-finite value the step's checks found (`None`: all finite so far);
    /// see [`NonFinite`].
    pub non_finite: Option<NonFinite>,
    /// What the contact phases of the last step found and hand on: pairs, colliding
    /// surfels, contact patches and the contact springs of the implicit solve (read
    /// them; the step rewrites them).
    pub contact: ContactState,
    /// Statistics of the run so far: phase times, deepest penetration, splits, dt
    /// changes, warnings.
    pub record: RunRecord,
    /// Id the next fragment gets (above every id seen).
    next_id: u32,
    /// `record.rest_renewals` at the last end of step (a renewal in this step asks for
    /// the stable dt again).
    renewals_seen: u64,
    /// Per index, the [`Object::serial`] of the object that `pairs`, `detections` and
    /// `patches` index (written by the broad phase): a contact phase run alone, and the
    /// contact energy, must not read them against another object list.
    contact_owner: Vec<u64>,
    /// Grids, boxes and scratch: rebuilt as needed, never the source of a result.
    cache: StepCache,
}

/// The contact state of a step, in the order the phases write it: each phase reads
/// what the ones before it wrote.
#[derive(Clone, Debug, Default)]
pub struct ContactState {
    /// Overlapping pairs, in a fixed order (indices into `World::objects`): written by
    /// `broad_phase`, read by `grids`, `detect`.
    pub pairs: Vec<Pair>,
    /// Colliding surfels of every overlapping pair: written by `detect`, read by
    /// `contact_surface`.
    pub detections: Vec<PairDetection>,
    /// Contact surfaces and their forces: written by `contact_surface`, `resample` and
    /// `forces`, read by `distribute` and `springs` (and by callers after the step).
    pub patches: Vec<ContactPatch>,
    /// The contact springs of the patches between implicit bodies (and between one and
    /// a static object): written by `springs`, read by the next step's `dynamics`
    /// ([`crate::solver`]).
    pub springs: ContactSprings,
    /// The friction springs' elongations of the patches' contact surfels
    /// ([`crate::contact::stick`]): written by `forces`, read by the next step's.
    pub stick: StickMemory,
}

impl ContactState {
    /// Forgets everything (the objects it indexes are gone).
    pub fn clear(&mut self) {
        self.pairs.clear();
        self.detections.clear();
        self.patches.clear();
        self.springs.clear();
        self.stick.clear();
    }
}

/// The contact state's fields read as the world's (`world.patches`), as before they
/// had a struct of their own.
impl std::ops::Deref for World {
    type Target = ContactState;

    fn deref(&self) -> &ContactState {
        &self.contact
    }
}

impl std::ops::DerefMut for World {
    fn deref_mut(&mut self) -> &mut ContactState {
        &mut self.contact
    }
}

/// A summary: the objects (each as [`Object`]'s summary), the step, the pairs and
/// contacts of the last step; not the caches and scratch.
impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("objects", &self.objects)
            .field("gravity", &self.gravity)
            .field("dt", &self.dt)
            .field("steps", &self.steps)
            .field("pairs", &self.contact.pairs.len())
            .field("patches", &self.contact.patches.len())
            .field("max_penetration", &self.record.max_penetration)
            .field("splits", &self.record.splits.len())
            .field("non_finite", &self.non_finite)
            .finish_non_exhaustive()
    }
}

impl World {
    /// A world of `objects` under `gravity` (m/s²) stepped by `dt` (s), taken as given:
    /// set it from [`World::stable_dt`] (its bound may be infinite, e.g. for static
    /// objects only: then pick one). Object ids must be distinct and below `u32::MAX`
    /// ([`World::step`] checks); fragments get ids above every id seen.
    ///
    /// # Panics
    ///
    /// If `gravity` is not finite (as [`World::step`] if it is changed later).
    pub fn new(objects: Vec<Object>, gravity: Vec3, dt: f32) -> Self {
        assert!(
            gravity.is_finite(),
            "World::new: gravity = {gravity}: must be finite"
        );
        let objects_next_id = objects
            .iter()
            .map(|o| o.id.saturating_add(1))
            .max()
            .unwrap_or(0);
        Self {
            objects,
            gravity,
            dt,
            keep_stable: true,
            render_contacts: false,
            resampled_forces: false,
            pairs_in_order: false,
            lazy_advection: false,
            sleep: true,
            preset: Preset::Default,
            steps: 0,
            time: 0.0,
            non_finite: None,
            contact: ContactState::default(),
            record: RunRecord::default(),
            next_id: objects_next_id,
            renewals_seen: 0,
            contact_owner: Vec::new(),
            cache: StepCache::default(),
        }
    }

    /// Largest stable time step over all objects (s) and the id of the object that
    /// limits it ([`World::object`]; owned, so `world.dt = world.stable_dt().0` needs no
    /// second borrow):
    /// each object's own dynamics, and, where two objects may touch, its contact spring
    /// ([`contact_stable_dt`]) unless its motion is prescribed ([`Object::is_prescribed`])
    /// or every moving object is implicit (its contacts are then springs in the solves). A backend's bound that is not a number > 0 (a
    /// broken [`crate::Dynamics::stable_dt`]) is the smallest, or NaN, which wins: it is
    /// returned with its object, not hidden.
    pub fn stable_dt(&self) -> (f32, Option<u32>) {
        // The stiffest partner any object could meet: the pair's E* and mean
        // `contact_stiffness` are largest against it, and the spring `κE*/h` takes the
        // finest spacing of the pair's moving objects (`contact_params`).
        let finest_moving = self
            .objects
            .iter()
            .filter(|o| !o.is_static())
            .map(|o| o.phyxel_spacing)
            .fold(f32::INFINITY, f32::min);
        let partner = (self.objects.len() >= 2).then(|| {
            self.objects
                .iter()
                .fold((f32::INFINITY, 0.0f32), |(c, k), o| {
                    (
                        c.min(compliance(&o.material)),
                        k.max(o.material.contact_stiffness),
                    )
                })
        });
        // Where every moving object is implicit or prescribed, every contact that moves
        // something joins an implicit solve
        // as springs ([`Object::contact_in_solve`]): no contact bound.
        let all_implicit = self.objects.iter().all(Object::may_join_solve);
        self.objects
            .iter()
            .map(|o| {
                let own = o.dynamics.stable_dt(&o.phyxels, &o.material);
                let contact = match partner {
                    // A prescribed body (a tool) moves as told whatever it receives.
                    Some((c, k)) if !o.is_prescribed() && !all_implicit => {
                        let e_star = 1.0 / (compliance(&o.material) + c);
                        let k = 0.5 * (o.material.contact_stiffness + k);
                        let h = o.phyxel_spacing;
                        let (rho, n) = (o.material.density, o.phyxels.len());
                        contact_stable_dt(k, e_star, rho, h, h.min(finest_moving), n)
                    }
                    _ => f32::INFINITY,
                };
                // A NaN bound (a broken backend) must win, not vanish in `min`.
                (if own.is_nan() { own } else { own.min(contact) }, o.id)
            })
            .fold((f32::INFINITY, None), |acc, (dt, o)| {
                // NaN (a broken backend) wins and stays, so callers see it.
                if acc.0.is_nan() {
                    acc
                } else if dt.is_nan() || dt < acc.0 {
                    (dt, Some(o))
                } else {
                    acc
                }
            })
    }

    /// The default time step (s) given the stable bound `stable` of
    /// [`World::stable_dt`]: [`DT_FRACTION`] of the bound, at most [`MAX_DEFAULT_DT`];
    /// a frame-rate step ([`crate::solver::DEFAULT_DT`]) where an implicit body moves and
    /// nothing bounds dt (every moving object implicit, contacts in the solves).
    pub fn default_dt(&self, stable: f32) -> f32 {
        let implicit = self
            .objects
            .iter()
            .any(|o| !o.is_static() && o.is_implicit());
        if stable == f32::INFINITY && implicit {
            crate::solver::DEFAULT_DT
        } else {
            (DT_FRACTION * stable).min(MAX_DEFAULT_DT)
        }
    }

    /// One time step: dynamics, surfel advection, contact handling, then topology.
    /// At the end, the first non-finite phyxel value (if any), or a moving body out of
    /// f32's range ([`NonFinite::out_of_range`]), is recorded in [`World::non_finite`]:
    /// check it to stop a run that has blown up.
    ///
    /// # Panics
    ///
    /// If `dt` is not a finite number > 0 (`World::new` takes it as given; `Scene::build`
    /// also checks it against [`World::stable_dt`]) or `gravity` not finite, if an
    /// object's surfel or phyxel columns no longer have the counts it was built with, or
    /// its phyxel masses, volumes, spacings or radii are not finite and > 0, before the
    /// step or after its backend's ([`Object::check_counts`]),
    /// if its material is invalid ([`crate::Material::validate`]), or if two objects
    /// share an id or one has the id `u32::MAX`. Each message names the object.
    pub fn step(&mut self) {
        self.step_until_topology();
        self.step_topology();
    }

    /// The step up to (not including) the topology phase; counts the step. With
    /// [`World::step_topology`] it makes one [`World::step`] (split so that the state
    /// just before a split can be inspected).
    pub fn step_until_topology(&mut self) {
        self.check_inputs();
        if !self.sleep {
            for o in self.objects.iter_mut().filter(|o| o.is_asleep()) {
                o.wake();
            }
        }
        let mut t = std::mem::take(&mut self.record.times);
        self.cache.arena.reset();
        let mut blocks_current = false;
        let end = [Phase::SelfCollision, Phase::Topology];
        // The phases that query the surfaces: lazily advected, one whose query reached
        // stale surfels runs again from `Detect`, with them current.
        let queries = [Phase::Detect, Phase::ContactSurface, Phase::Resample];
        for phase in Phase::ALL.into_iter().filter(|p| !end.contains(p)) {
            if phase == Phase::Grids && self.lazy_advection {
                let moved = t.time(Phase::Advect, || step::advect_near(self));
                t.add_work(Phase::Advect, moved);
            }
            let mut work = t.time(phase, || step::run(self, phase, blocks_current));
            if self.lazy_advection && queries.contains(&phase) {
                while t.time(Phase::Advect, || step::sync_missed(self)) {
                    self.record.lazy_reruns += 1;
                    for &p in queries.iter().take_while(|&&p| p != phase) {
                        t.time(p, || step::run(self, p, blocks_current));
                    }
                    work = t.time(phase, || step::run(self, phase, blocks_current));
                }
            }
            t.add_work(phase, work);
            // From the advection on, the block boxes bound every moving surfel.
            blocks_current |= phase == Phase::Advect;
        }
        self.record.times = t;
        self.steps += 1;
        self.time += self.dt as f64;
        self.record
            .contacts
            .add(&self.objects, &self.contact.patches, self.time, self.dt);
    }

    /// The topology phases of the step: self-collision forces, then fracture. Returns
    /// the number of objects that split. Ends the step with the finiteness check that sets
    /// [`World::non_finite`].
    pub fn step_topology(&mut self) -> usize {
        let mut t = std::mem::take(&mut self.record.times);
        let before = self.record.splits.len();
        for phase in [Phase::SelfCollision, Phase::Topology] {
            let work = t.time(phase, || step::run(self, phase, true));
            t.add_work(phase, work);
        }
        self.record.times = t;
        let splits = self.record.splits.len() - before;
        // (The pairs index the object list of this step's broad phase.)
        if self.sleep && self.objects_unchanged() {
            sleep::settle(
                &mut self.objects,
                &self.contact.pairs,
                &mut self.contact.springs,
                self.dt,
                self.time,
                &mut self.cache.sleep,
            );
        }
        if self.non_finite.is_none() {
            self.non_finite = self.find_non_finite();
        }
        let renewed = self.record.rest_renewals != self.renewals_seen;
        self.renewals_seen = self.record.rest_renewals;
        if self.keep_stable && (splits > 0 || renewed) {
            self.keep_dt_stable();
        }
        splits
    }

    /// Runs one phase of the step alone on the current state, untimed, as the step would
    /// run it (per-phase benches and profiles). The phases after it see its output;
    /// out of order, a phase works on whatever the last step left (e.g. `detect` on the
    /// last step's grids), and `dynamics` advances the phyxels.
    ///
    /// # Panics
    ///
    /// As [`World::step`]; and for a contact phase (`Grids` to `Springs`) when
    /// the object list changed since the last broad phase, whose pairs it would read
    /// (run `Phase::BroadPhase` or a step first).
    pub fn run_phase(&mut self, phase: Phase) {
        self.check_inputs();
        let contact = matches!(
            phase,
            Phase::Grids
                | Phase::Detect
                | Phase::ContactSurface
                | Phase::Resample
                | Phase::Forces
                | Phase::Distribute
                | Phase::Springs
        );
        assert!(
            !contact || self.objects_unchanged(),
            "World::run_phase({phase:?}): the objects changed since the last broad phase, \
             whose pairs this phase reads: run Phase::BroadPhase (or a step) first"
        );
        self.cache.arena.reset();
        step::run(self, phase, false);
    }

    /// The object with id `id`, wherever it is in [`World::objects`] (which a fracture
    /// reorders and extends); `None` if there is none, e.g. after it broke: its pieces
    /// have new ids and [`Object::parent`] = `Some(id)`.
    pub fn object(&self, id: u32) -> Option<&Object> {
        self.objects.iter().find(|o| o.id == id)
    }

    /// The index in [`World::objects`] of the object with id `id` (ids name objects in
    /// contact totals and summaries; indices change when an object fractures).
    pub fn index_of(&self, id: u32) -> Option<usize> {
        self.objects.iter().position(|o| o.id == id)
    }

    /// Mutable [`World::object`].
    pub fn object_mut(&mut self, id: u32) -> Option<&mut Object> {
        self.objects.iter_mut().find(|o| o.id == id)
    }

    /// The object named `name` (names are unique in a scene; a fracture's pieces are
    /// named `NAME.0`, `NAME.1`, ...); `None` if there is none.
    pub fn object_named(&self, name: &str) -> Option<&Object> {
        self.objects.iter().find(|o| o.name == name)
    }

    /// Total linear momentum of the moving objects (kg·m/s; static objects, which
    /// take up any momentum without moving, are left out).
    pub fn momentum(&self) -> [f64; 3] {
        let mut p = [0.0; 3];
        for o in self.objects.iter().filter(|o| !o.is_static()) {
            let q = o.phyxels.momentum();
            (0..3).for_each(|k| p[k] += q[k]);
        }
        p
    }

    /// Mechanical energy of the moving objects (J, f64 sums): kinetic, the elastic
    /// energy their backends report, the gravitational potential `−Σ m g·x` (zero at
    /// the origin) and the contact springs' ([`World::contact_energy`]). Without loads,
    /// the dashpots, friction and damping only take energy away, so a gain of their sum
    /// is a numerical failure (`run` warns of one).
    pub fn energy(&self) -> Energy {
        let g = self.gravity.as_dvec3();
        let mut e = Energy::default();
        for o in self.objects.iter().filter(|o| !o.is_static()) {
            let p = &o.phyxels;
            let d = o.dynamics.diagnostics(p, &o.material);
            e.kinetic += p.kinetic_energy();
            e.elastic += d.elastic_energy.unwrap_or(0.0);
            // Heights with the position sums' carries (`Phyxels::pos_carry`): at a small
            // dt the fall lives there for many steps while the velocity, and so the
            // kinetic energy, grows at once, which read as a false energy gain.
            e.potential -= (0..p.len())
                .map(|i| {
                    let x = p.pos.get(i).as_dvec3() + p.pos_carry.get(i).as_dvec3();
                    p.mass[i] as f64 * g.dot(x)
                })
                .sum::<f64>();
        }
        e.contact = self.contact_energy();
        e
    }

    /// Each contact pair's totals at the last contact phase (`contact::PatchTotals`: the
    /// objects' ids, force, torque, area, centroid, peak pressure, deepest overlap), in
    /// the order of `contact.patches`, torques about the
    /// midpoint of the two objects' centres of mass; per contact surfel,
    /// `contact::ContactPoint::of` over `patches[k].surfels`.
    pub fn contact_totals(&self) -> Vec<crate::contact::PatchTotals> {
        let com = |k: usize| glam::DVec3::from(self.objects[k].phyxels.centre_of_mass());
        self.contact
            .patches
            .iter()
            .map(|p| {
                let ids = [self.objects[p.a].id, self.objects[p.b].id];
                crate::contact::PatchTotals::of(p, ids, 0.5 * (com(p.a) + com(p.b)))
            })
            .collect()
    }

    /// Energy stored in the penalty springs at the last contact phase (J): over the
    /// contact surfels `Σ ¼ k A (|d₁| + |d₂|)²`, the spring force `½ A k (|d₁| + |d₂|)`
    /// integrated over the closure of the two surfaces (`contact::forces`; the dashpot
    /// and friction only dissipate). Bodies that start overlapping release it as kinetic
    /// energy. 0 before the first step, and when the objects changed since.
    pub fn contact_energy(&self) -> f64 {
        if !self.objects_unchanged() {
            return 0.0;
        }
        self.contact
            .patches
            .iter()
            .map(|patch| {
                let (a, b) = (&self.objects[patch.a], &self.objects[patch.b]);
                let k = contact_params(a, b, self.dt).stiffness as f64;
                let closure = |c: &ContactSurfel| {
                    let n = c.normal;
                    ((c.anchor_a - c.pos).dot(n).abs() + (c.anchor_b - c.pos).dot(n).abs()) as f64
                };
                patch
                    .surfels
                    .iter()
                    .map(|c| 0.25 * k * c.area as f64 * closure(c).powi(2))
                    .sum::<f64>()
            })
            // Not `sum`: an empty f64 sum is -0.0, which `run --json` printed as the
            // contact energy of every run without contact.
            .fold(0.0, |a, e| a + e)
    }

    /// Whether the object list is the one the last broad phase saw (its pairs and
    /// patches name objects by index).
    fn objects_unchanged(&self) -> bool {
        self.contact_owner.len() == self.objects.len()
            && self
                .objects
                .iter()
                .zip(&self.contact_owner)
                .all(|(o, &s)| o.serial() == s)
    }

    /// Drops the private cache (grids, boxes, scratch) to free its memory; the next step
    /// rebuilds it, with the same results as if it had been kept.
    pub fn clear_cache(&mut self) {
        self.cache = StepCache::default();
    }

    /// Moves every surfel that [`World::lazy_advection`] left behind to where the
    /// phyxels put it; returns how many.
    pub fn sync_surfels(&mut self) -> usize {
        use rayon::prelude::*;
        self.objects
            .par_iter_mut()
            .filter(|o| !o.surfels_current())
            .map(|o| o.sync_surfels())
            .sum()
    }

    /// Moves every object's output mesh with its phyxels (before a mesh frame is
    /// written: [`output::mesh_frame`]).
    pub fn follow_meshes(&mut self) {
        use rayon::prelude::*;
        self.objects
            .par_iter_mut()
            .filter(|o| o.mesh.is_some())
            .for_each(|o| o.follow_mesh());
    }

    /// True when every phyxel and surfel is finite.
    pub fn all_finite(&self) -> bool {
        self.objects
            .iter()
            .all(|o| o.phyxels.all_finite() && o.surfels.all_finite())
    }
}
