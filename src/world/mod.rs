//! The world and its step, read like the paper's `animate` (Keiser et al. 2004, §8).

pub mod phase;

use crate::body::fracture::{self, Components, SplitEvent};
use crate::body::object::Object;
use crate::contact::detect::{Candidates, DetectScratch, PairDetection, Volume, colliding_surfels};
use crate::contact::implicit::{ImplicitSurface, SurfelRows, grid_cell, radius_range};
use crate::contact::{
    self, ContactParams, ContactPatch, ContactSurfel, DistributeScratch, PairSurfaces, PatchScratch,
};
use crate::dynamics::{StepContext, damped_euler_limit};
use crate::spatial::broad_phase::{Aabb, Pair, overlapping_pairs, points_in_blocks};
use crate::spatial::grid::{Grid, LazyGrid};
use crate::world::phase::{Phase, PhaseTimes};
use bumpalo::Bump;
use bumpalo::collections::Vec as BumpVec;
use glam::Vec3;
use rayon::prelude::*;

/// All objects of a scene and the state of the run.
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
    /// Steps taken so far.
    pub steps: u64,
    /// Wall time and work per phase, summed over the run.
    pub times: PhaseTimes,
    /// Largest signed penetration depth of a colliding force carrier over the run (m).
    pub max_penetration: f32,
    /// Surfel bounding box per object (static objects: computed once).
    boxes: Vec<Aabb>,
    /// Overlapping pairs of this step, in a fixed order.
    pub pairs: Vec<Pair>,
    /// Surfel grid per object; rebuilt only for moving objects that are in a pair.
    grids: Vec<Option<Grid>>,
    /// Per index, the [`Object::serial`] of the object whose box and grids are cached
    /// there: static objects' are kept from step to step, so an object list that changed
    /// under them (reordered, replaced, even by an object of the same id) must not
    /// inherit them.
    cache_owner: Vec<u64>,
    /// True from this step's advection to the end of the step: every moving object's
    /// `SurfelBinding::block_boxes` bound its positions, so the broad phase, the grid
    /// regions and the candidate scans skip blocks that miss their boxes instead of
    /// reading every position. Cleared at the start of a step and of
    /// [`World::run_phase`] (the caller may have moved surfels in between).
    blocks_current: bool,
    /// Colliding surfels of every overlapping pair of this step.
    pub detections: Vec<PairDetection>,
    /// Contact surfaces and forces of this step.
    pub patches: Vec<ContactPatch>,
    /// Phyxel grids (current positions) of moving objects in contact.
    phyxel_grids: Vec<Option<Grid>>,
    /// Per object: the region its surfel grid covers and the on-demand grids.
    surface_grids: Vec<SurfaceGrids>,
    /// Build what the render surface `S \ C ∪ Φ` needs (only for output): resample the
    /// contact surfaces, and test every surfel for contact, not only the force carriers
    /// (`object::FORCE_CARRIER_SPACING`), so that `C` holds all colliding surfels. The
    /// forces and the motion are the same either way.
    pub render_contacts: bool,
    /// Contact surfels whose friction force was evaluated, summed over the run
    /// (zero when every pair has μ = 0: no friction work).
    pub friction_work: u64,
    /// Scratch that lives for one step (flags, index lists); reset at each step.
    arena: Bump,
    /// Per-pair detection scratch (both sides), reused from step to step.
    detect_scratch: Vec<[DetectScratch; 2]>,
    /// Per-patch contact scratch, reused from step to step.
    patch_scratch: Vec<PatchScratch>,
    /// Per-object distribution scratch, reused from step to step.
    distribute_scratch: Vec<DistributeScratch>,
    /// Every split so far, in order (the run summary's `fractures`).
    pub splits: Vec<SplitEvent>,
    /// Rest configurations renewed by plastic flow so far (all objects).
    pub rest_renewals: u64,
    /// `rest_renewals` at the last end of step (to notice a renewal in this step).
    renewals_seen: u64,
    /// Id the next fragment gets.
    next_id: u32,
    /// The first non-finite value the step's checks found (`None`: all finite so far);
    /// see [`NonFinite`].
    pub non_finite: Option<NonFinite>,
    /// Simulated time (s): the sum of the steps' `dt` (which may change between steps);
    /// loads ramp up over it.
    pub time: f64,
    /// Keep `dt` within the stable bound when the topology changes: after a step that
    /// renewed a rest shape or split an object, the bound is recomputed and, if it fell
    /// below `dt`, `dt` is lowered to 90% of it ([`DtChange`]). Default `true`;
    /// `Scene::build` sets it to `false` with `allow_unstable`.
    pub keep_stable: bool,
    /// Every lowering of `dt` so far, in order.
    pub dt_changes: Vec<DtChange>,
    /// What the world's builder found suspect but legal (`Scene::build`: a body too
    /// coarsely sampled for its mass, [`crate::scene::MASS_WARNING`]; two bodies whose
    /// start velocities close them faster than the P-wave speed); `run` prints them.
    pub warnings: Vec<String>,
}

/// `dt` lowered after a change of topology ([`World::keep_stable`]): a rest shape
/// renewed by plastic flow, or a fragment, can be much stiffer than the body the run
/// started with (a compressed, torn MLS rest stencil raised `ω_max` sevenfold), and an
/// explicit step above its bound gains energy without bound, often with no NaN.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DtChange {
    /// Step after which `dt` changed (1-based, as [`World::steps`]).
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

/// Mechanical energy of the moving objects (J): see [`World::energy`].
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Energy {
    pub kinetic: f64,
    pub elastic: f64,
    /// Gravitational, `−Σ m g·x` (zero at the origin).
    pub potential: f64,
    /// Stored in the contact penalty springs at the last contact phase
    /// ([`World::contact_energy`]; 0 before the first step).
    pub contact: f64,
}

impl Energy {
    /// Kinetic plus elastic plus potential plus contact.
    pub fn total(&self) -> f64 {
        self.kinetic + self.elastic + self.potential + self.contact
    }
}

/// Energy gain, as a fraction of the run's energy scale, above which `run` warns
/// ([`crate::app::summary::RunSummary::energy_warning`]): symplectic Euler's energy error
/// is bounded and small at a stable dt (below 1% in the built-in scenes), a blow-up's
/// gain is orders of magnitude.
pub const ENERGY_GAIN_WARNING: f64 = 0.1;

/// Fraction of the stable bound `dt` is lowered to ([`World::keep_stable`]): the
/// default dt's margin (`Scene::build`).
pub const DT_FRACTION: f32 = 0.9;

/// Largest default `dt` (s): when no object has a stable bound, and when the bound is
/// longer. Stability alone does not resolve motion: a material of 1e-38 Pa had a bound
/// of 2·10¹⁸ s, and its first steps under gravity fell past f32's range. No built-in
/// scene's bound reaches it (the softest, `soft-on-plane`, runs at 0.95 ms).
pub const MAX_DEFAULT_DT: f32 = 1e-3;

/// A summary: the objects (each as [`Object`]'s summary), the step, the pairs and
/// contacts of the last step; not the caches and scratch.
impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("objects", &self.objects)
            .field("gravity", &self.gravity)
            .field("dt", &self.dt)
            .field("steps", &self.steps)
            .field("pairs", &self.pairs.len())
            .field("patches", &self.patches.len())
            .field("max_penetration", &self.max_penetration)
            .field("splits", &self.splits.len())
            .field("non_finite", &self.non_finite)
            .finish_non_exhaustive()
    }
}

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
}

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
    fn find(o: &Object, step: u64, surfels: bool) -> Option<Self> {
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
        })
    }
}

impl std::fmt::Display for NonFinite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
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

/// The surfaces of the objects, for the phases that read pairs of them while writing
/// per-pair results elsewhere in the world.
struct SurfaceView<'w> {
    objects: &'w [Object],
    grids: &'w [Option<Grid>],
    surface_grids: &'w [SurfaceGrids],
}

impl SurfaceView<'_> {
    fn pair(&self, a: usize, b: usize) -> PairSurfaces<'_> {
        let (oa, ob) = (&self.objects[a], &self.objects[b]);
        PairSurfaces {
            a: self.surface(a),
            b: self.surface(b),
            surfels_a: &oa.surfels,
            surfels_b: &ob.surfels,
            carriers_a: &oa.force_carrier,
            carriers_b: &ob.force_carrier,
        }
    }

    /// The implicit surface of object `k` (its grids built this step).
    fn surface(&self, k: usize) -> ImplicitSurface<'_> {
        let s = &self.objects[k].surfels;
        let grid = self.grids[k].as_ref().expect("grid built for pairs");
        let sg = &self.surface_grids[k];
        let (r_min, r_max) = sg.radius_range;
        let surface =
            ImplicitSurface::with_radius_range(&s.pos, &s.normal, &s.radius, grid, r_min, r_max)
                .with_far_grid(&sg.far)
                .with_rows(&sg.rows);
        match sg.region {
            Some(region) => surface.with_region(region, &sg.members, &sg.all, &sg.far_region),
            None => surface,
        }
    }

    fn params(&self, a: usize, b: usize, dt: f32) -> ContactParams {
        contact_params(&self.objects[a], &self.objects[b], dt)
    }
}

/// Margin of an object's surfel-grid region around its pairs' intersection boxes, in
/// kernel reaches: detection, projections and root searches stay within a penetration
/// depth of the box, and queries that leave the region go to a grid of all surfels.
pub const GRID_REGION_MARGIN: f32 = 3.0;
/// The region's margin grows by this multiple of the object's deepest penetration of
/// the last step: a deep surfel's nearest surfels of the other object lie about its
/// depth away, and depths grow by a small fraction per step. Only speed depends on
/// it: queries that leave the region get the same answer from the grids of all surfels.
pub const GRID_REGION_DEPTH_FACTOR: f32 = 1.25;

/// The grids of one object's surfels besides the kernel grid, and what that grid covers.
#[derive(Debug, Default)]
struct SurfaceGrids {
    /// Coarse grid for far-field samples, built on first use in a step.
    far: LazyGrid,
    /// Deepest penetration of the last step's pairs of this object, either way (m).
    depth: f32,
    /// Grid of every surfel, built on first use, when the kernel grid covers a region.
    all: LazyGrid,
    /// The box whose surfels the kernel grid indexes (`None`: every surfel).
    region: Option<Aabb>,
    /// The surfels in `region` (scratch of the rebuild).
    members: Vec<u32>,
    /// Coarse far-field grid of the surfels in `region` (when there is one), built on
    /// first use in a step.
    far_region: LazyGrid,
    /// Smallest and largest surfel disk radius at the last rebuild.
    radius_range: (f32, f32),
    /// The kernel grid's surfel columns (the SIMD kernel sums over lane groups).
    rows: SurfelRows,
}

/// Support of the contact-force distribution kernel in influence radii. The paper uses
/// two of Müller's radii (3 r each, so 6 phyxel spacings); that spreads a contact force
/// over most of a small body, which then decelerates almost rigidly while the surfaces
/// overlap. One of our radii (2 r) keeps the force at the surface, where the elastic
/// response should start, and still reaches about 30 phyxels (docs/ARCHITECTURE.md).
pub const DISTRIBUTION_SUPPORT: f32 = 1.0;

/// Hertz compliance `(1 − ν²)/E` of a material: a pair's `E* = 1/(c_a + c_b)`.
fn compliance(m: &crate::body::material::Material) -> f32 {
    (1.0 - m.poisson * m.poisson) / m.young
}

/// Contact constants of a pair from the two materials (docs/ARCHITECTURE.md).
pub fn contact_params(a: &Object, b: &Object, dt: f32) -> ContactParams {
    let (ma, mb) = (&a.material, &b.material);
    let e_star = 1.0 / (compliance(ma) + compliance(mb));
    // The moving objects set the scale (both when neither moves).
    let any_moving = !a.is_static() || !b.is_static();
    let pick = [a, b]
        .into_iter()
        .filter(move |o| !any_moving || !o.is_static());
    let h = pick
        .clone()
        .map(|o| o.phyxel_spacing)
        .fold(f32::INFINITY, f32::min);
    let rho = pick
        .map(|o| o.material.density)
        .fold(f32::INFINITY, f32::min);
    let stiffness = 0.5 * (ma.contact_stiffness + mb.contact_stiffness) * e_star / h;
    let zeta = 0.5 * (ma.contact_damping + mb.contact_damping);
    ContactParams {
        lambda_a: ma.young / (ma.young + mb.young),
        lambda_b: mb.young / (ma.young + mb.young),
        stiffness,
        // Explicit integration damps stably only while c·dt < 2 m for the surface layer
        // (mass ρh per area) that takes the force: cap at 1.6 ρh/dt.
        damping: (2.0 * zeta * (stiffness * rho * h).sqrt()).min(1.6 * rho * h / dt),
        friction: (ma.friction * mb.friction).sqrt(),
        spacing: a.surfel_spacing.min(b.surfel_spacing),
        // The denser side's carriers set the density of Φ (without thinning: the
        // surfel spacing, as `spacing`).
        force_spacing: a.carrier_spacing.min(b.carrier_spacing),
    }
}

/// Thickness of the layer, in phyxel spacings, whose mass the contact spring moves: the
/// force spreads over the phyxels within twice the influence radius. Calibrated on the
/// stiffest backend for contact (`lj`, `two-spheres`, dt 0.8 ms): stable at
/// `contact_stiffness` 128, unstable at 256, which this layer puts at the bound.
pub const CONTACT_LAYER_SPACINGS: f32 = 2.5;
/// The layer, in spacings, that a body of `phyxels` phyxels can put behind its contact
/// surface: [`CONTACT_LAYER_SPACINGS`], or the body's own thickness (about `n^(1/3)`
/// spacings) when it is thinner. A one-phyxel body is one spacing thick: at the 2.5
/// spacings' bound two such spheres left a collision with twice their energy.
pub fn contact_layer(phyxels: usize) -> f32 {
    CONTACT_LAYER_SPACINGS.min((phyxels.max(1) as f32).cbrt())
}

/// Margin of the contact bound below the explicit limit (as the backends' own).
const CONTACT_STABILITY_MARGIN: f32 = 0.8;

/// Largest stable step (s) of the penalty spring `k = contact_stiffness · E*/h_pair` per
/// contact area (`h_pair`: the pair's finest moving phyxel spacing, as in
/// [`contact_params`]) acting on a layer of [`CONTACT_LAYER_SPACINGS`] of the object's
/// own spacings `h` of mass (`ρ · 2.5 h` per area): `0.8 · 2/ω` with
/// `ω² = k / (2.5 ρ h)`. With the default stiffness it is several times the elastic
/// bound; it binds when `contact_stiffness` is raised by orders of magnitude
/// (docs/SCENES.md, "Time step").
pub fn contact_stable_dt(
    contact_stiffness: f32,
    e_star: f32,
    density: f32,
    spacing: f32,
    pair_spacing: f32,
    phyxels: usize,
) -> f32 {
    let k = contact_stiffness * e_star / pair_spacing;
    let omega = (k / (contact_layer(phyxels) * density * spacing)).sqrt();
    CONTACT_STABILITY_MARGIN * damped_euler_limit(omega, 0.0)
}

/// The block boxes of `o`'s surfels when they bound its current positions (`current`:
/// [`World`]'s `blocks_current`; static objects are not advected, so never).
fn current_blocks(current: bool, o: &Object) -> Option<&[Aabb]> {
    (current && !o.is_static()).then(|| o.binding.block_boxes())
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
            steps: 0,
            times: PhaseTimes::default(),
            max_penetration: 0.0,
            boxes: Vec::new(),
            pairs: Vec::new(),
            grids: Vec::new(),
            detections: Vec::new(),
            patches: Vec::new(),
            phyxel_grids: Vec::new(),
            surface_grids: Vec::new(),
            cache_owner: Vec::new(),
            blocks_current: false,
            render_contacts: false,
            friction_work: 0,
            arena: Bump::new(),
            detect_scratch: Vec::new(),
            patch_scratch: Vec::new(),
            distribute_scratch: Vec::new(),
            splits: Vec::new(),
            rest_renewals: 0,
            renewals_seen: 0,
            next_id: objects_next_id,
            non_finite: None,
            time: 0.0,
            keep_stable: true,
            dt_changes: Vec::new(),
            warnings: Vec::new(),
        }
    }

    /// Largest stable time step over all objects (s) and the object that limits it:
    /// each object's own dynamics, and, where two objects may touch, its contact spring
    /// ([`contact_stable_dt`]). A backend's bound that is not a number > 0 (a broken
    /// [`crate::Dynamics::stable_dt`]) is the smallest, or NaN, which wins: it is returned with
    /// its object, not hidden.
    pub fn stable_dt(&self) -> (f32, Option<&Object>) {
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
        self.objects
            .iter()
            .map(|o| {
                let own = o.dynamics.stable_dt(&o.phyxels, &o.material);
                let contact = match partner {
                    Some((c, k)) if !o.is_static() => {
                        let e_star = 1.0 / (compliance(&o.material) + c);
                        let k = 0.5 * (o.material.contact_stiffness + k);
                        let h = o.phyxel_spacing;
                        let (rho, n) = (o.material.density, o.phyxels.len());
                        contact_stable_dt(k, e_star, rho, h, h.min(finest_moving), n)
                    }
                    _ => f32::INFINITY,
                };
                // A NaN bound (a broken backend) must win, not vanish in `min`.
                (if own.is_nan() { own } else { own.min(contact) }, o)
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

    /// One time step: dynamics, surfel advection, contact handling, then topology.
    /// At the end, the first non-finite phyxel value (if any) is recorded in
    /// [`World::non_finite`]: check it to stop a run that has blown up.
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
        let mut t = std::mem::take(&mut self.times);
        self.arena.reset();
        self.blocks_current = false;
        t.time(Phase::Dynamics, || self.dynamics());
        t.add_work(Phase::Dynamics, self.moving_phyxels());
        t.time(Phase::Advect, || self.advect());
        t.time(Phase::BroadPhase, || self.broad_phase());
        t.add_work(Phase::BroadPhase, self.pairs.len() as u64);
        let gridded = t.time(Phase::SurfelGrid, || self.surfel_grid());
        t.add_work(Phase::SurfelGrid, gridded);
        let tested = t.time(Phase::Detect, || self.detect());
        t.add_work(Phase::Detect, tested);
        let contacts = t.time(Phase::ContactSurface, || self.contact_surface());
        t.add_work(Phase::ContactSurface, contacts);
        let rendered = t.time(Phase::Resample, || self.resample());
        t.add_work(Phase::Resample, rendered);
        let (forced, rubbed) = t.time(Phase::Forces, || self.forces());
        t.add_work(Phase::Forces, forced);
        self.friction_work += rubbed;
        t.time(Phase::Distribute, || self.distribute());
        self.times = t;
        self.steps += 1;
        self.time += self.dt as f64;
    }

    /// What the step relies on and the caller may have changed (the fields are public):
    /// a finite dt > 0 and gravity, distinct object ids below `u32::MAX` (the caches and
    /// fragments key on them), valid materials, columns of the counts each object was
    /// built with, and phyxel masses, volumes, spacings and radii finite and > 0
    /// ([`Object::check_counts`]). A few comparisons per object, and one pass over four
    /// phyxel columns (15 µs for the 1M scene's 40k phyxels, under 0.1% of its step).
    fn check_inputs(&mut self) {
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

    /// The topology phase of the step: self-collision forces and fracture. Returns the
    /// number of objects that split. Ends the step with the finiteness check that sets
    /// [`World::non_finite`].
    pub fn step_topology(&mut self) -> usize {
        let mut t = std::mem::take(&mut self.times);
        let (work, splits) = t.time(Phase::Topology, || self.topology());
        t.add_work(Phase::Topology, work);
        self.times = t;
        if self.non_finite.is_none() {
            self.non_finite = self.find_non_finite();
        }
        let renewed = self.rest_renewals != self.renewals_seen;
        self.renewals_seen = self.rest_renewals;
        if self.keep_stable && (splits > 0 || renewed) {
            self.keep_dt_stable();
        }
        splits
    }

    /// Lowers `dt` to [`DT_FRACTION`] of the stable bound if it has fallen below `dt`
    /// ([`World::keep_stable`]). A bound that is not a number > 0 is left to the
    /// finiteness checks.
    fn keep_dt_stable(&mut self) {
        let (bound, limiter) = self.stable_dt();
        let Some(o) = limiter else {
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
        self.dt_changes.push(change);
    }

    /// The first moving object's first non-finite phyxel value (the end-of-step
    /// check; surfels are checked by the broad phase's boxes). A pass over 9 floats per
    /// phyxel: about 0.1% of a step of the 1M scene.
    fn find_non_finite(&self) -> Option<NonFinite> {
        self.objects
            .iter()
            .filter(|o| !o.is_static())
            .find_map(|o| NonFinite::find(o, self.steps, false))
    }

    /// Runs one phase of the step alone on the current state, untimed, as the step would
    /// run it (per-phase benches and profiles). The phases after it see its output;
    /// out of order, a phase works on whatever the last step left (e.g. `detect` on the
    /// last step's grids), and `dynamics` advances the phyxels.
    ///
    /// # Panics
    ///
    /// As [`World::step`]; and for a contact phase (`SurfelGrid` to `Distribute`) when
    /// the object list changed since the last broad phase, whose pairs it would read
    /// (run `Phase::BroadPhase` or a step first).
    pub fn run_phase(&mut self, phase: Phase) {
        self.check_inputs();
        let contact = matches!(
            phase,
            Phase::SurfelGrid
                | Phase::Detect
                | Phase::ContactSurface
                | Phase::Resample
                | Phase::Forces
                | Phase::Distribute
        );
        assert!(
            !contact || self.objects_unchanged(),
            "World::run_phase({phase:?}): the objects changed since the last broad phase, \
             whose pairs this phase reads: run Phase::BroadPhase (or a step) first"
        );
        self.arena.reset();
        self.blocks_current = false;
        match phase {
            Phase::Dynamics => self.dynamics(),
            Phase::Advect => self.advect(),
            Phase::BroadPhase => self.broad_phase(),
            Phase::SurfelGrid => {
                self.surfel_grid();
            }
            Phase::Detect => {
                self.detect();
            }
            Phase::ContactSurface => {
                self.contact_surface();
            }
            Phase::Resample => {
                self.resample();
            }
            Phase::Forces => {
                self.forces();
            }
            Phase::Distribute => self.distribute(),
            Phase::Topology => {
                self.topology();
            }
        }
    }

    fn moving_phyxels(&self) -> u64 {
        self.objects
            .iter()
            .filter(|o| !o.is_static())
            .map(|o| o.phyxels.len() as u64)
            .sum()
    }

    /// Each non-static object's backend advances its phyxels (under gravity, the
    /// contact forces of the previous step and the object's external load).
    #[inline(never)] // a named frame in flamegraphs
    fn dynamics(&mut self) {
        let (dt, gravity) = (self.dt, self.gravity);
        let t = self.time as f32;
        self.objects
            .par_iter_mut()
            .filter(|o| !o.is_static())
            .for_each(|o| {
                o.apply_load(t);
                let ctx = StepContext::new(dt, gravity, &o.material);
                o.dynamics.step(&mut o.phyxels, &ctx);
                // A backend may write the phyxels' columns: one that changed their count
                // would fail far from here, in the advection's binding.
                if let Err(e) = o.check_counts() {
                    panic!("World::step: after backend '{}': {e}", o.dynamics.name());
                }
            });
    }

    /// Surfels follow the phyxels of their object.
    #[inline(never)] // a named frame in flamegraphs
    fn advect(&mut self) {
        self.objects
            .par_iter_mut()
            .filter(|o| !o.is_static())
            .for_each(|o| o.advect_surfels());
        self.blocks_current = true;
        // Plastic flow that asked for a new rest shape gets it now that the surfels
        // have followed this step's motion.
        self.rest_renewals += self
            .objects
            .par_iter_mut()
            .filter(|o| !o.is_static() && o.dynamics.wants_new_rest())
            .map(|o| {
                o.renew_rest();
                1u64
            })
            .sum::<u64>();
    }

    /// Overlapping surfel bounding boxes and their intersection boxes.
    #[inline(never)] // a named frame in flamegraphs
    fn broad_phase(&mut self) {
        let n = self.objects.len();
        self.boxes.resize(n, Aabb::EMPTY);
        self.grids.resize_with(n, || None);
        self.cache_owner.resize(n, u64::MAX);
        for (k, o) in self.objects.iter().enumerate() {
            // A static object's box and grids are computed once, for the object at k.
            let fresh = self.cache_owner[k] != o.serial();
            if fresh {
                self.cache_owner[k] = o.serial();
                self.grids[k] = None;
            }
            if fresh || !o.is_static() {
                let surface = match current_blocks(self.blocks_current, o) {
                    Some(blocks) => Aabb::of_boxes(blocks),
                    None => Aabb::of(&o.surfels.pos),
                };
                if surface.is_non_finite() && self.non_finite.is_none() {
                    // (The step being taken: `steps` counts it at the end.)
                    self.non_finite = NonFinite::find(o, self.steps + 1, true);
                }
                // A static object's box holds its volume too: a closed surface holds
                // its phyxels, but an open one (a `plane`: surfels on top, phyxels
                // below) does not, and a box of its surfels alone is flat, so no surfel
                // of a body sinking into it was ever a candidate (a 2 cm ball fell
                // through a plane of 5 cm surfels). Moving bodies keep the surfels' box
                // (the paper's): in a fast impact the phyxels of a squashed sphere
                // reach past its surfels, and the larger box let surfels near them
                // count as deep inside (12 m/s: deepest 4.8 → 9.2 cm of 10).
                self.boxes[k] = if o.is_static() {
                    surface.union(&Aabb::of(&o.phyxels.pos))
                } else {
                    surface
                };
            }
        }
        let is_static =
            BumpVec::from_iter_in(self.objects.iter().map(|o| o.is_static()), &self.arena);
        overlapping_pairs(&self.boxes, &is_static, &mut self.pairs);
    }

    /// Surfel and phyxel grids of the objects in an overlapping pair (Teschner et al.
    /// 2003); static objects keep theirs, objects in no pair get none.
    #[inline(never)] // a named frame in flamegraphs
    fn surfel_grid(&mut self) -> u64 {
        let n = self.objects.len();
        self.grids.resize_with(n, || None);
        self.phyxel_grids.resize_with(n, || None);
        self.surface_grids.resize_with(n, SurfaceGrids::default);
        let mut needed = BumpVec::from_iter_in(std::iter::repeat_n(false, n), &self.arena);
        // The union of each object's pairs' intersection boxes.
        let mut near = BumpVec::from_iter_in(std::iter::repeat_n(Aabb::EMPTY, n), &self.arena);
        for p in &self.pairs {
            for k in [p.a, p.b] {
                needed[k] = true;
                near[k] = Aabb {
                    min: near[k].min.min(p.bounds.min),
                    max: near[k].max.max(p.bounds.max),
                };
            }
        }
        let objects = &self.objects;
        let (needed, near) = (&needed[..], &near[..]);
        let current = self.blocks_current;
        // Objects in parallel, and each object's two grids in parallel: a grid's counting
        // sort is serial, so this is where the cores share the phase. The far grid and
        // the grid of all surfels are only reset here: they are built if and when a
        // query needs them.
        self.grids
            .par_iter_mut()
            .zip(self.phyxel_grids.par_iter_mut())
            .zip(self.surface_grids.par_iter_mut())
            .enumerate()
            .map(|(k, ((g, pg), sg))| {
                let o = &objects[k];
                if !(needed[k] && (g.is_none() || !o.is_static())) {
                    return 0;
                }
                sg.radius_range = radius_range(&o.surfels.radius[..o.surfels.len()]);
                let cell = grid_cell(sg.radius_range.1).max(1e-6);
                let phyxel_cell = (DISTRIBUTION_SUPPORT * o.max_influence).max(1e-6);
                sg.far.reset();
                sg.all.reset();
                sg.far_region.reset();
                // A moving object's kernel grid covers the surfels near its contacts
                // only, unless that is most of them (static objects: built once, whole).
                let margin = GRID_REGION_MARGIN * cell + GRID_REGION_DEPTH_FACTOR * sg.depth;
                let region = Aabb {
                    min: near[k].min - margin,
                    max: near[k].max + margin,
                };
                sg.members.clear();
                if !o.is_static() {
                    let blocks = current_blocks(current, o);
                    points_in_blocks(&o.surfels.pos, blocks, &region, &mut sg.members);
                }
                let whole = o.is_static() || 2 * sg.members.len() > o.surfels.len();
                sg.region = (!whole).then_some(region);
                let SurfaceGrids { members, rows, .. } = sg;
                // Rebuilt in place: the grids keep their buffers between steps.
                rayon::join(
                    || {
                        let g = g.get_or_insert_default();
                        if whole {
                            g.rebuild_columns(&o.surfels.pos, cell)
                        } else {
                            g.rebuild_subset(&o.surfels.pos, members, cell);
                        }
                        let s = &o.surfels;
                        rows.rebuild(g, &s.pos, &s.normal, &s.radius);
                    },
                    || {
                        pg.get_or_insert_default()
                            .rebuild_columns(&o.phyxels.pos, phyxel_cell)
                    },
                );
                let indexed = if whole {
                    o.surfels.len()
                } else {
                    members.len()
                };
                (indexed + o.phyxels.len()) as u64
            })
            .sum()
    }

    /// Colliding surfels of every pair: surfels in the intersection box that are inside
    /// the other object (eq. 2).
    #[inline(never)] // a named frame in flamegraphs
    fn detect(&mut self) -> u64 {
        let n = self.pairs.len();
        // Results and scratch keep their buffers from earlier steps.
        self.detections.resize_with(n, Default::default);
        self.detect_scratch.resize_with(n, Default::default);
        let view = SurfaceView {
            objects: &self.objects,
            grids: &self.grids,
            surface_grids: &self.surface_grids,
        };
        let phyxel_grids = &self.phyxel_grids;
        // Without a render surface only the force carriers' contacts are used: the
        // other surfels are not tested (a million-surfel sphere on 20k phyxels has one
        // carrier in four or five surfels).
        let render = self.render_contacts;
        let current = self.blocks_current;
        let side = |surfels, k: usize| {
            let o = &view.objects[k];
            Candidates {
                surfels,
                blocks: current_blocks(current, o),
                only: (!render).then(|| &o.force_carrier[..]),
            }
        };
        let volume = |k: usize| Volume {
            phyxels: phyxel_grids[k].as_ref().expect("grid built for pairs"),
            reach: view.objects[k].phyxel_spacing,
        };
        self.detections
            .par_iter_mut()
            .zip(self.detect_scratch.par_iter_mut())
            .zip(self.pairs.par_iter())
            .for_each(|((d, [sa, sb]), pair)| {
                let s = view.pair(pair.a, pair.b);
                d.a = pair.a;
                d.b = pair.b;
                // Both sides at once: each writes its own list from its own scratch.
                let (na, nb) = rayon::join(
                    || {
                        colliding_surfels(
                            side(s.surfels_a, pair.a),
                            &s.b,
                            &volume(pair.b),
                            pair,
                            sa,
                            &mut d.a_in_b,
                        )
                    },
                    || {
                        colliding_surfels(
                            side(s.surfels_b, pair.b),
                            &s.a,
                            &volume(pair.a),
                            pair,
                            sb,
                            &mut d.b_in_a,
                        )
                    },
                );
                d.candidates = na + nb;
            });
        for sg in &mut self.surface_grids {
            sg.depth = 0.0;
        }
        for d in &self.detections {
            // Over the force carriers, whether or not the others were tested, so that
            // writing frames does not change the reported depth.
            let carrier = |k: usize| {
                let c = &self.objects[k].force_carrier;
                move |s: u32| c[s as usize]
            };
            let depth = d.max_depth_of(carrier(d.a), carrier(d.b));
            self.max_penetration = self.max_penetration.max(depth);
            for k in [d.a, d.b] {
                let sg = &mut self.surface_grids[k];
                sg.depth = sg.depth.max(depth);
            }
        }
        self.detections.iter().map(|d| d.candidates as u64).sum()
    }

    /// Colliding surfels moved onto the contact surface Φ (paper §6).
    #[inline(never)] // a named frame in flamegraphs
    fn contact_surface(&mut self) -> u64 {
        let touching = BumpVec::from_iter_in(
            self.detections
                .iter()
                .filter(|d| !d.a_in_b.is_empty() || !d.b_in_a.is_empty()),
            &self.arena,
        );
        self.patches.resize_with(touching.len(), Default::default);
        self.patch_scratch
            .resize_with(touching.len(), Default::default);
        let view = SurfaceView {
            objects: &self.objects,
            grids: &self.grids,
            surface_grids: &self.surface_grids,
        };
        let dt = self.dt;
        self.patches
            .par_iter_mut()
            .zip(self.patch_scratch.par_iter_mut())
            .zip(touching.par_iter())
            .for_each(|((patch, scratch), d)| {
                let p = view.params(d.a, d.b, dt);
                contact::contact_surface(d, &view.pair(d.a, d.b), &p, scratch, patch);
            });
        self.patches.iter().map(|p| p.surfels.len() as u64).sum()
    }

    /// Even, hole-free resampling of each contact surface for the render surface;
    /// skipped when nothing is rendered.
    #[inline(never)] // a named frame in flamegraphs
    fn resample(&mut self) -> u64 {
        if !self.render_contacts {
            return 0;
        }
        let view = SurfaceView {
            objects: &self.objects,
            grids: &self.grids,
            surface_grids: &self.surface_grids,
        };
        let dt = self.dt;
        self.patches.par_iter_mut().for_each(|patch| {
            let p = view.params(patch.a, patch.b, dt);
            contact::resample(patch, &view.pair(patch.a, patch.b), &p);
        });
        self.patches.iter().map(|p| p.render.len() as u64).sum()
    }

    /// Penalty and friction forces on the contact surfels (paper §7). Returns the
    /// contact surfels forced and, of those, the ones whose pair has friction.
    #[inline(never)] // a named frame in flamegraphs
    fn forces(&mut self) -> (u64, u64) {
        let view = SurfaceView {
            objects: &self.objects,
            grids: &self.grids,
            surface_grids: &self.surface_grids,
        };
        let dt = self.dt;
        let with_friction: u64 = self
            .patches
            .par_iter_mut()
            .zip(self.patch_scratch.par_iter_mut())
            .map(|(patch, scratch)| {
                let p = view.params(patch.a, patch.b, dt);
                contact::forces(patch, &p, scratch);
                if p.friction > 0.0 {
                    patch.surfels.len() as u64
                } else {
                    0
                }
            })
            .sum();
        let forced = self.patches.iter().map(|p| p.surfels.len() as u64).sum();
        (forced, with_friction)
    }

    /// Contact forces spread onto the phyxels of moving objects (their grids were built
    /// this step with the surfel grids); they act at the next step. Parallel over
    /// objects: each object takes its patches in patch order, so the sums do not depend
    /// on the thread count.
    #[inline(never)] // a named frame in flamegraphs
    fn distribute(&mut self) {
        let n = self.objects.len();
        self.distribute_scratch.resize_with(n, Default::default);
        let (patches, grids) = (&self.patches, &self.phyxel_grids);
        self.objects
            .par_iter_mut()
            .zip(self.distribute_scratch.par_iter_mut())
            .enumerate()
            .filter(|(_, (o, _))| !o.is_static())
            .for_each(|(k, (o, scratch))| {
                let h = DISTRIBUTION_SUPPORT * o.max_influence;
                for patch in patches {
                    let sign = match (patch.a == k, patch.b == k) {
                        (true, _) => 1.0f32,
                        (_, true) => -1.0,
                        _ => continue,
                    };
                    let grid = grids[k].as_ref().expect("grid built for pairs");
                    contact::distribute(&patch.surfels, sign, &mut o.phyxels, grid, h, scratch);
                }
            });
    }

    /// Self-collision forces (objects with `self_collision`), then fracture of the objects
    /// whose backend and material can break ([`crate::body::fracture`]). Returns the work
    /// (phyxels checked) and the number of objects that split; both zero when no object
    /// uses either feature.
    #[inline(never)] // a named frame in flamegraphs
    fn topology(&mut self) -> (u64, usize) {
        let mut work = 0;
        for o in self.objects.iter_mut().filter(|o| !o.is_static()) {
            if let Some(sc) = &mut o.self_collision {
                work += o.phyxels.len() as u64;
                sc.apply(&mut o.phyxels, &o.material, self.dt);
            }
        }
        if !self.objects.iter().any(fracture::may_fracture) {
            return (work, 0);
        }
        // Each object that may break counts its components (a spanning-tree check
        // unless the tree broke: crate::body::connectivity), in parallel over objects.
        let (checked, breaking) = self
            .objects
            .par_iter_mut()
            .filter(|o| fracture::may_fracture(o))
            .map(|o| {
                let p = &o.phyxels;
                let count = o.connectivity.update(&p.pos, &p.radius);
                (p.len() as u64, usize::from(count > 1))
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        work += checked;
        if breaking == 0 {
            return (work, 0);
        }
        // A body that has gone non-finite falls apart in the component count; it is
        // left whole for the end-of-step check to report (its pieces could not be built).
        let finite = |o: &Object| {
            [&o.phyxels.pos, &o.surfels.pos, &o.surfels.normal]
                .iter()
                .all(|c| c.first_non_finite().is_none())
        };
        let broken: Vec<(usize, Components)> = (0..self.objects.len())
            .filter(|&k| {
                let o = &self.objects[k];
                fracture::may_fracture(o) && o.connectivity.count() > 1 && finite(o)
            })
            .map(|k| (k, self.objects[k].connectivity.components()))
            .collect();
        // Pieces: the first takes the broken object's place (other objects keep their
        // indices, so static objects keep their grids), the others are appended.
        let mut objects: Vec<Option<Object>> = std::mem::take(&mut self.objects)
            .into_iter()
            .map(Some)
            .collect();
        let mut appended = Vec::new();
        let mut splits = 0;
        for (k, comps) in broken {
            let o = objects[k].take().expect("each object splits once per step");
            match fracture::split(o, &comps, self.steps, &mut self.next_id) {
                Ok((pieces, event)) => {
                    let mut pieces = pieces.into_iter();
                    objects[k] = pieces.next();
                    appended.extend(pieces);
                    self.splits.push(event);
                    splits += 1;
                }
                Err(o) => objects[k] = Some(*o),
            }
        }
        self.objects = objects.into_iter().flatten().collect();
        self.objects.extend(appended);
        // This step's detections and patches index the old objects' surfels.
        self.detections.clear();
        self.patches.clear();
        (work, splits)
    }

    /// The object with id `id`, wherever it is in [`World::objects`] (which a fracture
    /// reorders and extends); `None` if there is none, e.g. after it broke: its pieces
    /// have new ids and [`Object::parent`] = `Some(id)`.
    pub fn object(&self, id: u32) -> Option<&Object> {
        self.objects.iter().find(|o| o.id == id)
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

    /// Energy stored in the penalty springs at the last contact phase (J): over the
    /// contact surfels `Σ ¼ k A (|d₁| + |d₂|)²`, the spring force `½ A k (|d₁| + |d₂|)`
    /// integrated over the closure of the two surfaces (`contact::forces`; the dashpot
    /// and friction only dissipate). Bodies that start overlapping release it as kinetic
    /// energy. 0 before the first step, and when the objects changed since.
    pub fn contact_energy(&self) -> f64 {
        if !self.objects_unchanged() {
            return 0.0;
        }
        self.patches
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
        self.cache_owner.len() == self.objects.len()
            && self
                .objects
                .iter()
                .zip(&self.cache_owner)
                .all(|(o, &s)| o.serial() == s)
    }

    /// True when every phyxel and surfel is finite.
    pub fn all_finite(&self) -> bool {
        self.objects
            .iter()
            .all(|o| o.phyxels.all_finite() && o.surfels.all_finite())
    }
}
