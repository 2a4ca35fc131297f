//! The phases of one step (Keiser et al. 2004, §8), one `#[inline(never)]` function
//! each, so that a flamegraph names them as the timing table does
//! (`phyxel::world::step::detect`). Each phase takes what it reads and writes what it
//! produces, as its signature says: the contact state travels
//! `pairs → detections → patches → springs` ([`ContactState`]), the grids and scratch
//! are the cache's. [`run`] dispatches the phases of [`Phase::ALL`] to them. The one
//! value a phase keeps from step to step besides the contact state is each object's
//! last penetration depth in the cache, which sizes the next grid region (speed only).

use super::cache::{
    EAGER_AFTER_MISS, GRID_REGION_DEPTH_FACTOR, GRID_REGION_MARGIN, ObjectGrids, StepCache,
    SurfaceGrids, SurfaceView, current_blocks,
};
use super::guard::NonFinite;
use super::phase::Phase;
use super::{ContactState, RunRecord, World, sleep};
use crate::body::fracture::{self, Components};
use crate::body::object::Object;
use crate::contact;
use crate::contact::detect::{Candidates, PairDetection, Volume, colliding_surfels};
use crate::contact::field::{grid_cell, radius_range};
use crate::contact::stick::StickMemory;
use crate::contact::{ContactPatch, StickContext};
use crate::par;
use crate::solver::{ContactSprings, Solver};
use crate::spatial::broad_phase::{Aabb, BLOCK, Pair, overlapping_pairs, points_in_blocks};
use bumpalo::Bump;
use bumpalo::collections::Vec as BumpVec;
use glam::Vec3;
use rayon::prelude::*;

/// What every phase may read of the step besides its inputs.
#[derive(Clone, Copy, Debug)]
struct Settings {
    /// Time step (s) and gravity (m/s²).
    dt: f32,
    gravity: Vec3,
    /// Simulated time at the step's start (s): loads ramp over it.
    time: f32,
    /// The step being taken (1 for the first).
    step: u64,
    /// Test every surfel for contact and resample Φ (`World::render_contacts`).
    render_contacts: bool,
    /// Forces on the resampled Φ (`World::resampled_forces`).
    resampled_forces: bool,
    /// This step's advection has run, so every moving object's block boxes bound its
    /// surfels and the scans may skip blocks by them.
    blocks_current: bool,
    /// Advect only the surfels the step reads (`World::lazy_advection`; not with
    /// pairs in order, whose working surfaces read every surfel).
    lazy: bool,
}

/// Runs `phase` of `w` on its current state and returns its work count (the timing
/// table's work column).
pub(super) fn run(w: &mut World, phase: Phase, blocks_current: bool) -> u64 {
    let s = Settings {
        dt: w.dt,
        gravity: w.gravity,
        time: w.time as f32,
        step: w.steps + 1,
        render_contacts: w.render_contacts,
        resampled_forces: w.resampled_forces,
        blocks_current,
        lazy: lazy(w),
    };
    match phase {
        Phase::Dynamics => {
            // The springs name objects by index: only for the object list they were
            // built on.
            if !w.objects_unchanged() {
                w.contact.springs.clear();
            }
            dynamics(&mut w.objects, &w.contact.springs, &mut w.cache.solver, &s)
        }
        Phase::Advect => {
            // Lazily, except for objects whose queries reached stale surfels lately.
            let surface = &w.cache.grids.surface;
            let eager = |k: usize| {
                !s.lazy
                    || surface
                        .get(k)
                        .is_some_and(|g| g.missed_at > 0 && s.step < g.missed_at + EAGER_AFTER_MISS)
            };
            let eager = BumpVec::from_iter_in((0..w.objects.len()).map(eager), &w.cache.arena);
            advect(&mut w.objects, &eager, &mut w.record)
        }
        Phase::BroadPhase => {
            let work = broad_phase(
                &w.objects,
                &s,
                &mut w.cache,
                &mut w.record,
                &mut w.non_finite,
                &mut w.contact.pairs,
            );
            // A woken body's pairs with other sleeping bodies were skipped: find the
            // pairs again until nothing more wakes.
            while sleep::wake_touched(&mut w.objects, &w.contact.pairs) {
                let frozen = frozen(&w.objects, &w.cache.arena);
                overlapping_pairs(&w.cache.boxes, &frozen, &mut w.contact.pairs);
            }
            w.contact_owner.clear();
            w.contact_owner.extend(w.objects.iter().map(|o| o.serial()));
            work
        }
        Phase::Grids => {
            let c = &mut w.cache;
            grids(&w.objects, &w.contact.pairs, &s, &mut c.grids, &c.arena)
        }
        Phase::Detect => detect(
            &w.objects,
            &w.contact.pairs,
            &s,
            &mut w.cache,
            &mut w.record,
            &mut w.contact.detections,
        ),
        Phase::ContactSurface if w.pairs_in_order => super::in_order::contact_in_order(w),
        Phase::ContactSurface => contact_surface(
            &w.objects,
            &w.contact.detections,
            &s,
            &mut w.cache,
            &mut w.contact.patches,
        ),
        Phase::Resample if w.pairs_in_order && (s.render_contacts || s.resampled_forces) => {
            // Done pair by pair in the contact-surface phase.
            w.contact
                .patches
                .iter()
                .map(|p| p.render.len() as u64)
                .sum()
        }
        Phase::Resample => resample(&w.objects, &s, &w.cache.grids, &mut w.contact.patches),
        Phase::Forces => forces(
            &w.objects,
            &s,
            &mut w.cache,
            &mut w.record,
            &mut w.contact.patches,
            &mut w.contact.stick,
        ),
        Phase::Distribute => distribute(&mut w.objects, &w.contact.patches, &mut w.cache),
        Phase::Springs => {
            let c = &mut w.cache;
            springs(
                &w.objects,
                &w.contact.patches,
                &w.contact.detections,
                &s,
                &c.grids,
                &mut c.solver,
                &mut w.contact.springs,
            )
        }
        Phase::SelfCollision => self_collision(&mut w.objects, &s),
        Phase::Topology => topology(
            &mut w.objects,
            &mut w.contact,
            w.steps,
            &mut w.next_id,
            &mut w.record,
        ),
    }
}

/// Whether this step advects lazily (`Settings::lazy`).
fn lazy(w: &World) -> bool {
    w.lazy_advection && !w.pairs_in_order
}

fn moving_phyxels(objects: &[Object]) -> u64 {
    objects
        .iter()
        .filter(|o| !o.is_static())
        .map(|o| o.phyxels.len() as u64)
        .sum()
}

/// Each non-static object's backend advances its phyxels (under gravity, the
/// contact forces of the previous step and the object's external load); implicit
/// bodies by islands joined by the last step's contact `springs` ([`crate::solver`]).
#[inline(never)] // a named frame in flamegraphs
fn dynamics(
    objects: &mut [Object],
    springs: &ContactSprings,
    solver: &mut Solver,
    s: &Settings,
) -> u64 {
    solver.step(objects, springs, s.dt, s.gravity, s.time, check_counts);
    moving_phyxels(objects)
}

/// A backend may write the phyxels' columns: one that changed their count would fail
/// far from here, in the advection's binding.
fn check_counts(o: &Object) {
    if let Err(e) = o.check_counts() {
        panic!("World::step: after backend '{}': {e}", o.dynamics.name());
    }
}

/// Surfels follow the phyxels of their object; plastic flow that asked for a new rest
/// shape gets it (counted in `record.rest_renewals`). Unless `eager` (per object), a
/// moving object only tabulates its field and advects the blocks that outline its box
/// ([`Object::advect_outline`]): [`advect_near`] moves those near its contacts once the
/// broad phase has found them.
#[inline(never)] // a named frame in flamegraphs
fn advect(objects: &mut [Object], eager: &[bool], record: &mut RunRecord) -> u64 {
    let grain = par::grain(objects.iter().map(|o| !o.is_frozen()));
    let moved: usize = objects
        .par_iter_mut()
        .with_min_len(grain)
        .zip(eager)
        .map(|(o, &eager)| match (o.is_frozen(), eager) {
            // Asleep: its phyxels have not moved since the table was made.
            (true, _) => o.sync_surfels(),
            (false, true) => o.advect_surfels(),
            (false, false) => {
                o.prepare_surfels();
                o.advect_outline()
            }
        })
        .sum();
    // Now that the surfels have followed this step's motion.
    let renews = |o: &Object| !o.is_static() && o.dynamics.wants_new_rest();
    let grain = par::grain(objects.iter().map(renews));
    record.rest_renewals += objects
        .par_iter_mut()
        .with_min_len(grain)
        .filter(|o| renews(o))
        .map(|o| {
            o.sync_surfels();
            o.renew_rest();
            1u64
        })
        .sum::<u64>();
    moved as u64
}

/// The box whose surfels the kernel grid of an object indexes (its pairs'
/// intersection boxes `near`, grown by the kernel's reach for surfels of disk radius up
/// to `r_max` and by the last step's depth), and the grid's cell.
fn grid_region(r_max: f32, near: &Aabb, depth: f32) -> (Aabb, f32) {
    let cell = grid_cell(r_max).max(1e-6);
    let margin = GRID_REGION_MARGIN * cell + GRID_REGION_DEPTH_FACTOR * depth;
    let region = Aabb {
        min: near.min - margin,
        max: near.max + margin,
    };
    (region, cell)
}

/// Each object's pairs' intersection boxes, united (`Aabb::EMPTY` for an object in no
/// pair).
fn pair_boxes<'a>(n: usize, pairs: &[Pair], arena: &'a Bump) -> BumpVec<'a, Aabb> {
    let mut near = BumpVec::from_iter_in(std::iter::repeat_n(Aabb::EMPTY, n), arena);
    for p in pairs {
        for k in [p.a, p.b] {
            near[k] = Aabb {
                min: near[k].min.min(p.bounds.min),
                max: near[k].max.max(p.bounds.max),
            };
        }
    }
    near
}

/// With lazy advection, before the grids: each moving object in a pair advects the
/// blocks that meet its grid region, or all of them when the grid will hold every
/// surfel (the blocks there are most of the object). Returns the surfels moved.
#[inline(never)] // a named frame in flamegraphs
pub(super) fn advect_near(w: &mut World) -> u64 {
    let n = w.objects.len();
    let near = pair_boxes(n, &w.contact.pairs, &w.cache.arena);
    let near = &near[..];
    let surface = &w.cache.grids.surface;
    let depth = |k: usize| surface.get(k).map_or(0.0, |sg| sg.depth);
    let wanted = |k: usize, o: &Object| near[k] != Aabb::EMPTY && !o.surfels_current();
    let grain = par::grain(w.objects.iter().enumerate().map(|(k, o)| wanted(k, o)));
    w.objects
        .par_iter_mut()
        .with_min_len(grain)
        .enumerate()
        .filter(|(k, o)| wanted(*k, o))
        .map(|(k, o)| {
            let (_, r_max) = radius_range(&o.surfels.radius[..o.surfels.len()]);
            let (region, _) = grid_region(r_max, &near[k], depth(k));
            let meets = |b: &Aabb| b.is_non_finite() || b.intersection(&region).is_some();
            let blocks = o.binding.block_boxes().iter().filter(|b| meets(b)).count();
            // `grids` indexes all surfels when more than half lie in the region: then
            // every block is read.
            let moved = if 2 * blocks * BLOCK > o.surfels.len() {
                o.sync_surfels()
            } else {
                o.advect_surfels_in(&region)
            };
            moved as u64
        })
        .sum()
}

/// With lazy advection, after a phase that queried the surfaces: the objects whose
/// queries left their grid region while some of their surfels were stale (the grids of
/// all surfels would have read them) are brought current, and their grids of all
/// surfels dropped. True if any was: the contact phases from `detect` on are then run
/// again, with the same results as if every surfel had been advected.
pub(super) fn sync_missed(w: &mut World) -> bool {
    let mut any = false;
    for (o, sg) in w.objects.iter_mut().zip(w.cache.grids.surface.iter_mut()) {
        if sg.missed.swap(false, std::sync::atomic::Ordering::Relaxed) {
            sg.missed_at = w.steps + 1;
            o.sync_surfels();
            sg.all.reset();
            sg.far.reset();
            any = true;
        }
    }
    any
}

/// Overlapping surfel bounding boxes and their intersection boxes, written to `pairs`;
/// the boxes are kept in the cache, a body beyond f32's reach or non-finite is recorded
/// in `non_finite`, a crossing in `record.warnings`.
#[inline(never)] // a named frame in flamegraphs
fn broad_phase(
    objects: &[Object],
    s: &Settings,
    cache: &mut StepCache,
    record: &mut RunRecord,
    non_finite: &mut Option<NonFinite>,
    pairs: &mut Vec<Pair>,
) -> u64 {
    let n = objects.len();
    cache.boxes.resize(n, Aabb::EMPTY);
    cache.previous_boxes.clone_from(&cache.boxes);
    cache.margins.clear();
    cache.margins.extend(
        objects
            .iter()
            .map(|o| crate::solver::springs::margin(o, s.dt, s.gravity)),
    );
    cache.grids.surfel.resize_with(n, || None);
    cache.owner.resize(n, u64::MAX);
    for (k, o) in objects.iter().enumerate() {
        // A static object's box and grids are computed once, for the object at k.
        let fresh = cache.owner[k] != o.serial();
        if fresh {
            cache.owner[k] = o.serial();
            cache.grids.surfel[k] = None;
            cache.previous_boxes[k] = Aabb::EMPTY;
        }
        if fresh || !o.is_static() {
            let surface = match current_blocks(s.blocks_current, o) {
                Some(blocks) => Aabb::of_boxes(blocks),
                None => Aabb::of(&o.surfels.pos),
            };
            if surface.is_non_finite() && non_finite.is_none() {
                *non_finite = NonFinite::find(o, s.step, true);
            }
            if !o.is_static() && non_finite.is_none() {
                *non_finite = NonFinite::beyond_range(o, &surface, s.step);
            }
            // A static object's box holds its volume too: a closed surface holds
            // its phyxels, but an open one (a `plane`: surfels on top, phyxels
            // below) does not, and a box of its surfels alone is flat, so no surfel
            // of a body sinking into it would be a candidate. Moving bodies keep the
            // surfels' box (the paper's): in a fast impact the phyxels of a squashed
            // body reach past its surfels, and a box of both lets surfels near them
            // count as deep inside.
            cache.boxes[k] = if o.is_static() {
                surface.union(&Aabb::of(&o.phyxels.pos))
            } else if cache.margins[k] > 0.0 {
                surface.widened(cache.margins[k])
            } else {
                surface
            };
        }
    }
    if !cache.crossing_warned
        && let Some(warning) = super::guard::crossing_warning(
            objects,
            &cache.previous_boxes,
            &cache.boxes,
            s.step,
            s.dt,
        )
    {
        cache.crossing_warned = true;
        record.warnings.push(warning);
    }
    let frozen = frozen(objects, &cache.arena);
    overlapping_pairs(&cache.boxes, &frozen, pairs);
    pairs.len() as u64
}

/// Per object, whether it does not move this step (static or asleep): pairs of two such
/// objects are skipped.
fn frozen<'a>(objects: &[Object], arena: &'a Bump) -> BumpVec<'a, bool> {
    BumpVec::from_iter_in(objects.iter().map(Object::is_frozen), arena)
}

/// Surfel and phyxel grids of the objects in an overlapping pair (Teschner et al.
/// 2003); static objects keep theirs, objects in no pair get none.
#[inline(never)] // a named frame in flamegraphs
fn grids(
    objects: &[Object],
    pairs: &[Pair],
    s: &Settings,
    grids: &mut ObjectGrids,
    arena: &Bump,
) -> u64 {
    let n = objects.len();
    grids.surfel.resize_with(n, || None);
    grids.phyxel.resize_with(n, || None);
    grids.surface.resize_with(n, SurfaceGrids::default);
    // The union of each object's pairs' intersection boxes.
    let near = pair_boxes(n, pairs, arena);
    let needed = BumpVec::from_iter_in(near.iter().map(|b| *b != Aabb::EMPTY), arena);
    let (needed, near) = (&needed[..], &near[..]);
    let current = s.blocks_current;
    // Objects in parallel, and each object's two grids in parallel: a grid's counting
    // sort is serial, so this is where the cores share the phase. The far grid and
    // the grid of all surfels are only reset here: they are built if and when a
    // query needs them.
    let builds = |k: usize, g: &Option<_>| needed[k] && (g.is_none() || !objects[k].is_static());
    let grain = par::grain(grids.surfel.iter().enumerate().map(|(k, g)| builds(k, g)));
    grids
        .surfel
        .par_iter_mut()
        .zip(grids.phyxel.par_iter_mut())
        .zip(grids.surface.par_iter_mut())
        .with_min_len(grain)
        .enumerate()
        .map(|(k, ((g, pg), sg))| {
            let o = &objects[k];
            if !builds(k, g) {
                return 0;
            }
            sg.radius_range = radius_range(&o.surfels.radius[..o.surfels.len()]);
            let phyxel_cell = o.distribution_radius().max(1e-6);
            sg.far.reset();
            sg.all.reset();
            sg.far_region.reset();
            // A moving object's kernel grid covers the surfels near its contacts
            // only, unless that is most of them (static objects: built once, whole).
            let (region, cell) = grid_region(sg.radius_range.1, &near[k], sg.depth);
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
/// the other object (eq. 2), written to `detections`; the deepest penetration goes to
/// `record.max_penetration` and, per object, to the cache (it sizes the next grids).
#[inline(never)] // a named frame in flamegraphs
fn detect(
    objects: &[Object],
    pairs: &[Pair],
    s: &Settings,
    cache: &mut StepCache,
    record: &mut RunRecord,
    detections: &mut Vec<PairDetection>,
) -> u64 {
    let n = pairs.len();
    // Results and scratch keep their buffers from earlier steps.
    detections.resize_with(n, Default::default);
    cache.detect.resize_with(n, Default::default);
    let view = SurfaceView::new(objects, &cache.grids);
    let phyxel_grids = &cache.grids.phyxel;
    let cache_margins = &cache.margins;
    // Without a render surface only the force carriers' contacts are used: the
    // other surfels are not tested (a million-surfel sphere on 20k phyxels has one
    // carrier in four or five surfels).
    let render = s.render_contacts;
    let current = s.blocks_current;
    let side = |surfels, k: usize, margin: f32| {
        let o = &view.objects[k];
        Candidates {
            surfels,
            blocks: current_blocks(current, o),
            only: (!render).then(|| &o.force_carrier[..]),
            margin,
        }
    };
    let volume = |k: usize| Volume {
        phyxels: phyxel_grids[k].as_ref().expect("grid built for pairs"),
        reach: view.objects[k].phyxel_spacing,
    };
    detections
        .par_iter_mut()
        .zip(cache.detect.par_iter_mut())
        .zip(pairs.par_iter())
        .for_each(|((d, [sa, sb]), pair)| {
            let s = view.pair(pair.a, pair.b);
            d.a = pair.a;
            d.b = pair.b;
            // Gaps only for a contact that an implicit solve takes as springs.
            let (oa, ob) = (&objects[pair.a], &objects[pair.b]);
            let margin = if oa.contact_in_solve(ob) {
                cache_margins[pair.a] + cache_margins[pair.b]
            } else {
                0.0
            };
            // Both sides at once: each writes its own list from its own scratch.
            let (na, nb) = rayon::join(
                || {
                    colliding_surfels(
                        side(s.surfels_a, pair.a, margin),
                        &s.b,
                        &volume(pair.b),
                        pair,
                        sa,
                        &mut d.a_in_b,
                        &mut d.a_near_b,
                    )
                },
                || {
                    colliding_surfels(
                        side(s.surfels_b, pair.b, margin),
                        &s.a,
                        &volume(pair.a),
                        pair,
                        sb,
                        &mut d.b_in_a,
                        &mut d.b_near_a,
                    )
                },
            );
            d.candidates = na + nb;
        });
    for sg in &mut cache.grids.surface {
        sg.depth = 0.0;
    }
    for d in detections.iter() {
        // Over the force carriers, whether or not the others were tested, so that
        // writing frames does not change the reported depth.
        let carrier = |k: usize| {
            let c = &objects[k].force_carrier;
            move |s: u32| c[s as usize]
        };
        let depth = d.max_depth_of(carrier(d.a), carrier(d.b));
        record.max_penetration = record.max_penetration.max(depth);
        for k in [d.a, d.b] {
            let sg = &mut cache.grids.surface[k];
            sg.depth = sg.depth.max(depth);
        }
    }
    detections.iter().map(|d| d.candidates as u64).sum()
}

/// Colliding surfels moved onto the contact surface Φ (paper §6), one patch per
/// touching pair, written to `patches`.
#[inline(never)] // a named frame in flamegraphs
fn contact_surface(
    objects: &[Object],
    detections: &[PairDetection],
    s: &Settings,
    cache: &mut StepCache,
    patches: &mut Vec<ContactPatch>,
) -> u64 {
    let touching = BumpVec::from_iter_in(
        detections
            .iter()
            .filter(|d| !d.a_in_b.is_empty() || !d.b_in_a.is_empty()),
        &cache.arena,
    );
    patches.resize_with(touching.len(), Default::default);
    cache.patch.resize_with(touching.len(), Default::default);
    let view = SurfaceView::new(objects, &cache.grids);
    let dt = s.dt;
    patches
        .par_iter_mut()
        .zip(cache.patch.par_iter_mut())
        .zip(touching.par_iter())
        .for_each(|((patch, scratch), d)| {
            let p = view.params(d.a, d.b, dt);
            contact::contact_surface(d, &view.pair(d.a, d.b), &p, scratch, patch);
        });
    patches.iter().map(|p| p.surfels.len() as u64).sum()
}

/// Even, hole-free resampling of each contact surface for the render surface and, with
/// `World::resampled_forces`, as the contact surfels the forces act on; skipped when
/// neither needs it.
#[inline(never)] // a named frame in flamegraphs
fn resample(
    objects: &[Object],
    s: &Settings,
    grids: &ObjectGrids,
    patches: &mut [ContactPatch],
) -> u64 {
    if !(s.render_contacts || s.resampled_forces) {
        return 0;
    }
    let view = SurfaceView::new(objects, grids);
    let (dt, on_resampled) = (s.dt, s.resampled_forces);
    patches.par_iter_mut().for_each(|patch| {
        let p = view.params(patch.a, patch.b, dt);
        let pair = view.pair(patch.a, patch.b);
        contact::resample(patch, &pair, &p);
        if on_resampled {
            contact::anchor(&mut patch.render, &patch.surfels, &pair, &p);
            patch.surfels.clone_from(&patch.render);
        }
    });
    patches.iter().map(|p| p.render.len() as u64).sum()
}

/// Penalty and friction forces on the contact surfels of `patches` (paper §7). Returns
/// the contact surfels forced; those of pairs with friction are added to
/// `record.friction_work`.
#[inline(never)] // a named frame in flamegraphs
fn forces(
    objects: &[Object],
    s: &Settings,
    cache: &mut StepCache,
    record: &mut RunRecord,
    patches: &mut [ContactPatch],
    memory: &mut StickMemory,
) -> u64 {
    let view = SurfaceView::new(objects, &cache.grids);
    let (dt, on_resampled) = (s.dt, s.resampled_forces);
    let last = &*memory;
    let with_friction: u64 = patches
        .par_iter_mut()
        .zip(cache.patch.par_iter_mut())
        .map(|(patch, scratch)| {
            let mut p = view.params(patch.a, patch.b, dt);
            if on_resampled {
                // Resampled Φ has the surfel spacing, whatever the carriers'.
                p.force_spacing = p.spacing;
            }
            let stick = StickContext {
                memory: last,
                a: objects[patch.a].serial(),
                b: objects[patch.b].serial(),
                dt,
            };
            contact::forces(patch, &p, scratch, &stick);
            if p.friction > 0.0 {
                patch.surfels.len() as u64
            } else {
                0
            }
        })
        .sum();
    record.friction_work += with_friction;
    contact::keep_sticks(patches, |k| objects[k].serial(), memory, dt);
    patches.iter().map(|p| p.surfels.len() as u64).sum()
}

/// Contact forces spread onto the phyxels of moving objects (their grids were built
/// this step with the surfel grids); they act at the next step. Parallel over
/// objects: each object takes its patches in patch order, so the sums do not depend
/// on the thread count. The patches of pairs whose contact joins an implicit solve are
/// left to the `springs` phase.
#[inline(never)] // a named frame in flamegraphs
fn distribute(objects: &mut [Object], patches: &[ContactPatch], cache: &mut StepCache) -> u64 {
    let n = objects.len();
    cache.distribute.resize_with(n, Default::default);
    let in_solve = BumpVec::from_iter_in(
        patches
            .iter()
            .map(|p| objects[p.a].contact_in_solve(&objects[p.b])),
        &cache.arena,
    );
    let in_solve = &in_solve[..];
    let grids = &cache.grids.phyxel;
    // The moving objects that take a force spread here.
    let mut takes = BumpVec::from_iter_in(objects.iter().map(|_| false), &cache.arena);
    for (p, _) in patches.iter().zip(in_solve).filter(|e| !*e.1) {
        takes[p.a] = true;
        takes[p.b] = true;
    }
    for (t, o) in takes.iter_mut().zip(objects.iter()) {
        *t &= !o.is_frozen();
    }
    let takes = &takes[..];
    let grain = par::grain(takes.iter().copied());
    objects
        .par_iter_mut()
        .zip(cache.distribute.par_iter_mut())
        .with_min_len(grain)
        .enumerate()
        .filter(|(k, _)| takes[*k])
        .for_each(|(k, (o, scratch))| {
            let h = o.distribution_radius();
            for (patch, _) in patches.iter().zip(in_solve.iter()).filter(|e| !*e.1) {
                let sign = match (patch.a == k, patch.b == k) {
                    (true, _) => 1.0f32,
                    (_, true) => -1.0,
                    _ => continue,
                };
                let grid = grids[k].as_ref().expect("grid built for pairs");
                contact::distribute(&patch.surfels, sign, &mut o.phyxels, grid, h, scratch);
            }
        });
    0
}

/// The contact springs of the patches between implicit bodies, written to `springs`
/// for the next step's solve ([`Solver::renew_springs`]). Returns the springs.
#[inline(never)] // a named frame in flamegraphs
fn springs(
    objects: &[Object],
    patches: &[ContactPatch],
    detections: &[PairDetection],
    s: &Settings,
    grids: &ObjectGrids,
    solver: &mut Solver,
    springs: &mut ContactSprings,
) -> u64 {
    solver.renew_springs(springs, patches, detections, objects, &grids.phyxel, s.dt);
    springs.springs.len() as u64
}

/// Self-collision forces of the objects with `self_collision` (paper §8). Returns the
/// phyxels checked.
#[inline(never)] // a named frame in flamegraphs
fn self_collision(objects: &mut [Object], s: &Settings) -> u64 {
    let mut work = 0;
    for o in objects.iter_mut().filter(|o| !o.is_frozen()) {
        if let Some(sc) = &mut o.self_collision {
            work += o.phyxels.len() as u64;
            sc.apply(&mut o.phyxels, &o.material, s.dt);
        }
    }
    work
}

/// Fracture of the objects whose backend and material can break
/// ([`crate::body::fracture`]): each split is recorded in `record.splits`, and the
/// contact state, which indexes the old objects, is cleared. Returns the phyxels
/// checked: zero when no object may break.
#[inline(never)] // a named frame in flamegraphs
fn topology(
    objects: &mut Vec<Object>,
    contact: &mut ContactState,
    steps: u64,
    next_id: &mut u32,
    record: &mut RunRecord,
) -> u64 {
    if !objects.iter().any(fracture::may_fracture) {
        return 0;
    }
    // Each object that may break counts its components (a spanning-tree check
    // unless the tree broke: crate::body::connectivity), in parallel over objects.
    let grain = par::grain(objects.iter().map(fracture::may_fracture));
    let (checked, breaking) = objects
        .par_iter_mut()
        .with_min_len(grain)
        .filter(|o| fracture::may_fracture(o))
        .map(|o| {
            let p = &o.phyxels;
            let count = o.connectivity.update(&p.pos, &p.radius);
            (p.len() as u64, usize::from(count > 1))
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if breaking == 0 {
        return checked;
    }
    // Splitting reads every surfel of the breaking objects.
    for o in objects.iter_mut() {
        o.sync_surfels();
    }
    // A body that has gone non-finite falls apart in the component count; it is
    // left whole for the end-of-step check to report (its pieces could not be built).
    let finite = |o: &Object| {
        [&o.phyxels.pos, &o.surfels.pos, &o.surfels.normal]
            .iter()
            .all(|c| c.first_non_finite().is_none())
    };
    let broken: Vec<(usize, Components)> = (0..objects.len())
        .filter(|&k| {
            let o = &objects[k];
            fracture::may_fracture(o) && o.connectivity.count() > 1 && finite(o)
        })
        .map(|k| (k, objects[k].connectivity.components()))
        .collect();
    // Pieces: the first takes the broken object's place (other objects keep their
    // indices, so static objects keep their grids), the others are appended.
    let mut slots: Vec<Option<Object>> = std::mem::take(objects).into_iter().map(Some).collect();
    let mut appended = Vec::new();
    for (k, comps) in broken {
        let o = slots[k].take().expect("each object splits once per step");
        match fracture::split(o, &comps, steps, next_id) {
            Ok((pieces, event)) => {
                let mut pieces = pieces.into_iter();
                slots[k] = pieces.next();
                appended.extend(pieces);
                record.splits.push(event);
            }
            Err(o) => slots[k] = Some(*o),
        }
    }
    *objects = slots.into_iter().flatten().collect();
    objects.extend(appended);
    // This step's detections, patches and springs index the old objects' surfels.
    contact.detections.clear();
    contact.patches.clear();
    contact.springs.clear();
    checked
}
