//! The world's private cache: per-object grids and boxes, and scratch reused from step
//! to step so that the steady step allocates nothing, and the view of the surfaces the
//! contact phases share. Nothing here is a result: dropped
//! ([`World::clear_cache`](super::World::clear_cache)), it is rebuilt by the next step
//! with the same bits. One value is handed from a step to the next: each object's
//! deepest penetration ([`SurfaceGrids::depth`]), which only sizes a grid region.

use crate::body::object::Object;
use crate::contact::detect::DetectScratch;
use crate::contact::field::{SurfaceField, SurfelRows};
use crate::contact::params::contact_params;
use crate::contact::{ContactParams, DistributeScratch, PairSurfaces, PatchScratch};
use crate::spatial::broad_phase::Aabb;
use crate::spatial::grid::{Grid, LazyGrid};
use bumpalo::Bump;
use std::sync::atomic::AtomicBool;

/// Grids, boxes and scratch of the step.
#[derive(Default)]
pub(super) struct StepCache {
    /// Surfel bounding box per object (static objects: computed once), widened by its
    /// margin.
    pub boxes: Vec<Aabb>,
    /// Per object, how far outside another object its surfels are found as gaps for an
    /// implicit solve (m; [`crate::solver::springs::margin`]).
    pub margins: Vec<f32>,
    /// `boxes` of the step before (empty for an object new at its index): how far each
    /// body moved in a step ([`super::guard::crossing_warning`]).
    pub previous_boxes: Vec<Aabb>,
    /// A crossing warning was given (one per run).
    pub crossing_warned: bool,
    /// Per index, the [`Object::serial`] of the object whose box and grids are cached
    /// there: static objects' are kept from step to step, so an object list that changed
    /// under them (reordered, replaced, even by an object of the same id) must not
    /// inherit them.
    pub owner: Vec<u64>,
    /// The grids of each object's surfels and phyxels.
    pub grids: ObjectGrids,
    /// Scratch that lives for one step (flags, index lists); reset at each step.
    pub arena: Bump,
    /// Per-pair detection scratch (both sides).
    pub detect: Vec<[DetectScratch; 2]>,
    /// Per-patch contact scratch.
    pub patch: Vec<PatchScratch>,
    /// Per-object distribution scratch.
    pub distribute: Vec<DistributeScratch>,
    /// The implicit solve's islands and buffers.
    pub solver: crate::solver::Solver,
    /// The surfaces and scratch of pairs handled in order (`World::pairs_in_order`).
    pub in_order: super::in_order::InOrderScratch,
    /// The sleep test's groups.
    pub sleep: super::sleep::SleepScratch,
}

/// Per object, the grids of the objects in a pair (rebuilt each step for moving objects,
/// once for static ones; objects in no pair get none).
#[derive(Default)]
pub(super) struct ObjectGrids {
    /// The kernel grid of the surfels (near the object's contacts, or all of them).
    pub surfel: Vec<Option<Grid>>,
    /// What the kernel grid covers, and the coarser grids beside it.
    pub surface: Vec<SurfaceGrids>,
    /// Grid of the phyxels' current positions (detection's volume test, distribution).
    pub phyxel: Vec<Option<Grid>>,
}

/// The surfaces of the objects, for the phases that read pairs of them while writing
/// per-pair results elsewhere in the world.
pub(super) struct SurfaceView<'w> {
    pub objects: &'w [Object],
    grids: &'w ObjectGrids,
}

impl<'w> SurfaceView<'w> {
    pub fn new(objects: &'w [Object], grids: &'w ObjectGrids) -> Self {
        Self { objects, grids }
    }

    pub fn pair(&self, a: usize, b: usize) -> PairSurfaces<'_> {
        let (oa, ob) = (&self.objects[a], &self.objects[b]);
        PairSurfaces {
            a: self.surface(a),
            b: self.surface(b),
            surfels_a: &oa.surfels,
            surfels_b: &ob.surfels,
            carriers_a: &oa.force_carrier,
            carriers_b: &ob.force_carrier,
            carrier_spacing_a: oa.carrier_spacing,
            carrier_spacing_b: ob.carrier_spacing,
        }
    }

    /// The implicit surface of object `k` (its grids built this step).
    pub fn surface(&self, k: usize) -> SurfaceField<'_> {
        let s = &self.objects[k].surfels;
        let grid = self.grids.surfel[k].as_ref().expect("grid built for pairs");
        let sg = &self.grids.surface[k];
        let (r_min, r_max) = sg.radius_range;
        let surface =
            SurfaceField::with_radius_range(&s.pos, &s.normal, &s.radius, grid, r_min, r_max)
                .with_far_grid(&sg.far)
                .with_rows(&sg.rows);
        let current = self.objects[k].surfels_current();
        match sg.region {
            Some(region) => surface
                .with_region(region, &sg.members, &sg.all, &sg.far_region)
                .with_stale_outside((!current).then_some(&sg.missed)),
            None => {
                debug_assert!(current, "a grid of every surfel over stale surfels");
                surface
            }
        }
    }

    pub fn params(&self, a: usize, b: usize, dt: f32) -> ContactParams {
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
pub(super) struct SurfaceGrids {
    /// Coarse grid for far-field samples, built on first use in a step.
    pub far: LazyGrid,
    /// Deepest penetration of the last step's pairs of this object, either way (m):
    /// written by `detect`, read by the next step's `grids` to size the region
    /// (speed only: queries outside the region get the same answer from `all`).
    pub depth: f32,
    /// Grid of every surfel, built on first use, when the kernel grid covers a region.
    pub all: LazyGrid,
    /// The box whose surfels the kernel grid indexes (`None`: every surfel).
    pub region: Option<Aabb>,
    /// The surfels in `region` (scratch of the rebuild).
    pub members: Vec<u32>,
    /// Coarse far-field grid of the surfels in `region` (when there is one), built on
    /// first use in a step.
    pub far_region: LazyGrid,
    /// Set when a query of this step's surfaces needed the grids of all surfels while
    /// some surfels were stale (`World::lazy_advection`): the step syncs the object and
    /// runs its contact phases again.
    pub missed: AtomicBool,
    /// The last step whose queries set `missed` (0: none): the object then advects
    /// every surfel for [`EAGER_AFTER_MISS`] steps, so that a contact whose queries keep
    /// leaving the region does not run its contact phases twice at every step.
    pub missed_at: u64,
    /// Smallest and largest surfel disk radius at the last rebuild.
    pub radius_range: (f32, f32),
    /// The kernel grid's surfel columns (the SIMD kernel sums over lane groups).
    pub rows: SurfelRows,
}

/// Steps an object advects all its surfels after its surface queries reached stale
/// surfels ([`SurfaceGrids::missed_at`]): one rerun of the contact phases per this many
/// steps at most, while such queries go on (speed only).
pub const EAGER_AFTER_MISS: u64 = 50;

/// The block boxes of `o`'s surfels when they bound its current positions (`current`:
/// this step's advection has run; static objects are not advected, so never).
pub(super) fn current_blocks(current: bool, o: &Object) -> Option<&[Aabb]> {
    (current && !o.is_static()).then(|| o.binding.block_boxes())
}
