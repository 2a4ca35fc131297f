//! The phases of one step (Keiser et al. 2004, §8), one `#[inline(never)]` function
//! each, so that a flamegraph names them as the timing table does
//! (`phyxel::world::step::detect`). [`run`] dispatches the phases of [`Phase::ALL`] to
//! them. A value one phase hands to a later one travels as an argument
//! (`blocks_current`) or in the world's contact state (`pairs`, `detections`,
//! `patches`); the one value kept from step to step is each object's last penetration
//! depth in the cache, which sizes the next grid region (speed only).

use super::World;
use super::cache::{
    GRID_REGION_DEPTH_FACTOR, GRID_REGION_MARGIN, SurfaceGrids, SurfaceView, current_blocks,
};
use super::guard::NonFinite;
use super::phase::Phase;
use crate::body::fracture::{self, Components};
use crate::body::object::Object;
use crate::contact;
use crate::contact::detect::{Candidates, Volume, colliding_surfels};
use crate::contact::field::{grid_cell, radius_range};
use crate::spatial::broad_phase::{Aabb, overlapping_pairs, points_in_blocks};
use bumpalo::collections::Vec as BumpVec;
use rayon::prelude::*;

/// Runs `phase` of `w` on its current state and returns its work count (the timing table's
/// work column). `blocks_current`: this step's advection has run, so every moving
/// object's block boxes bound its surfels and the scans may skip blocks by them.
pub(super) fn run(w: &mut World, phase: Phase, blocks_current: bool) -> u64 {
    match phase {
        Phase::Dynamics => dynamics(w),
        Phase::Advect => advect(w),
        Phase::BroadPhase => broad_phase(w, blocks_current),
        Phase::SurfelGrid => surfel_grid(w, blocks_current),
        Phase::Detect => detect(w, blocks_current),
        Phase::ContactSurface => contact_surface(w),
        Phase::Resample => resample(w),
        Phase::Forces => forces(w),
        Phase::Distribute => distribute(w),
        Phase::Topology => topology(w),
    }
}

fn moving_phyxels(w: &World) -> u64 {
    w.objects
        .iter()
        .filter(|o| !o.is_static())
        .map(|o| o.phyxels.len() as u64)
        .sum()
}

/// Each non-static object's backend advances its phyxels (under gravity, the
/// contact forces of the previous step and the object's external load); implicit
/// bodies by islands joined by the last step's contact springs ([`crate::solver`]).
#[inline(never)] // a named frame in flamegraphs
fn dynamics(w: &mut World) -> u64 {
    // The springs name objects by index: only for the object list they were built on.
    if !w.objects_unchanged() {
        w.springs.clear();
    }
    let t = w.time as f32;
    w.cache
        .solver
        .step(&mut w.objects, &w.springs, w.dt, w.gravity, t, check_counts);
    moving_phyxels(w)
}

/// A backend may write the phyxels' columns: one that changed their count would fail
/// far from here, in the advection's binding.
fn check_counts(o: &Object) {
    if let Err(e) = o.check_counts() {
        panic!("World::step: after backend '{}': {e}", o.dynamics.name());
    }
}

/// Surfels follow the phyxels of their object.
#[inline(never)] // a named frame in flamegraphs
fn advect(w: &mut World) -> u64 {
    w.objects
        .par_iter_mut()
        .filter(|o| !o.is_static())
        .for_each(|o| o.advect_surfels());
    // Plastic flow that asked for a new rest shape gets it now that the surfels
    // have followed this step's motion.
    w.record.rest_renewals += w
        .objects
        .par_iter_mut()
        .filter(|o| !o.is_static() && o.dynamics.wants_new_rest())
        .map(|o| {
            o.renew_rest();
            1u64
        })
        .sum::<u64>();
    0
}

/// Overlapping surfel bounding boxes and their intersection boxes.
#[inline(never)] // a named frame in flamegraphs
fn broad_phase(w: &mut World, blocks_current: bool) -> u64 {
    let n = w.objects.len();
    w.cache.boxes.resize(n, Aabb::EMPTY);
    w.cache.previous_boxes.clone_from(&w.cache.boxes);
    w.cache.grids.surfel.resize_with(n, || None);
    w.cache.owner.resize(n, u64::MAX);
    for (k, o) in w.objects.iter().enumerate() {
        // A static object's box and grids are computed once, for the object at k.
        let fresh = w.cache.owner[k] != o.serial();
        if fresh {
            w.cache.owner[k] = o.serial();
            w.cache.grids.surfel[k] = None;
            w.cache.previous_boxes[k] = Aabb::EMPTY;
        }
        if fresh || !o.is_static() {
            let surface = match current_blocks(blocks_current, o) {
                Some(blocks) => Aabb::of_boxes(blocks),
                None => Aabb::of(&o.surfels.pos),
            };
            if surface.is_non_finite() && w.non_finite.is_none() {
                // (The step being taken: `steps` counts it at the end.)
                w.non_finite = NonFinite::find(o, w.steps + 1, true);
            }
            if !o.is_static() && w.non_finite.is_none() {
                w.non_finite = NonFinite::beyond_range(o, &surface, w.steps + 1);
            }
            // A static object's box holds its volume too: a closed surface holds
            // its phyxels, but an open one (a `plane`: surfels on top, phyxels
            // below) does not, and a box of its surfels alone is flat, so no surfel
            // of a body sinking into it was ever a candidate (a 2 cm ball fell
            // through a plane of 5 cm surfels). Moving bodies keep the surfels' box
            // (the paper's): in a fast impact the phyxels of a squashed sphere
            // reach past its surfels, and the larger box let surfels near them
            // count as deep inside (12 m/s: deepest 4.8 → 9.2 cm of 10).
            w.cache.boxes[k] = if o.is_static() {
                surface.union(&Aabb::of(&o.phyxels.pos))
            } else {
                surface
            };
        }
    }
    if !w.cache.crossing_warned
        && let Some(warning) = super::guard::crossing_warning(
            &w.objects,
            &w.cache.previous_boxes,
            &w.cache.boxes,
            w.steps + 1,
            w.dt,
        )
    {
        w.cache.crossing_warned = true;
        w.record.warnings.push(warning);
    }
    let is_static = BumpVec::from_iter_in(w.objects.iter().map(|o| o.is_static()), &w.cache.arena);
    overlapping_pairs(&w.cache.boxes, &is_static, &mut w.pairs);
    w.contact_owner.clear();
    w.contact_owner.extend(w.objects.iter().map(|o| o.serial()));
    w.pairs.len() as u64
}

/// Surfel and phyxel grids of the objects in an overlapping pair (Teschner et al.
/// 2003); static objects keep theirs, objects in no pair get none.
#[inline(never)] // a named frame in flamegraphs
fn surfel_grid(w: &mut World, blocks_current: bool) -> u64 {
    let n = w.objects.len();
    w.cache.grids.surfel.resize_with(n, || None);
    w.cache.grids.phyxel.resize_with(n, || None);
    w.cache.grids.surface.resize_with(n, SurfaceGrids::default);
    let mut needed = BumpVec::from_iter_in(std::iter::repeat_n(false, n), &w.cache.arena);
    // The union of each object's pairs' intersection boxes.
    let mut near = BumpVec::from_iter_in(std::iter::repeat_n(Aabb::EMPTY, n), &w.cache.arena);
    for p in &w.pairs {
        for k in [p.a, p.b] {
            needed[k] = true;
            near[k] = Aabb {
                min: near[k].min.min(p.bounds.min),
                max: near[k].max.max(p.bounds.max),
            };
        }
    }
    let objects = &w.objects;
    let (needed, near) = (&needed[..], &near[..]);
    let current = blocks_current;
    // Objects in parallel, and each object's two grids in parallel: a grid's counting
    // sort is serial, so this is where the cores share the phase. The far grid and
    // the grid of all surfels are only reset here: they are built if and when a
    // query needs them.
    w.cache
        .grids
        .surfel
        .par_iter_mut()
        .zip(w.cache.grids.phyxel.par_iter_mut())
        .zip(w.cache.grids.surface.par_iter_mut())
        .enumerate()
        .map(|(k, ((g, pg), sg))| {
            let o = &objects[k];
            if !(needed[k] && (g.is_none() || !o.is_static())) {
                return 0;
            }
            sg.radius_range = radius_range(&o.surfels.radius[..o.surfels.len()]);
            let cell = grid_cell(sg.radius_range.1).max(1e-6);
            let phyxel_cell = o.distribution_radius().max(1e-6);
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
fn detect(w: &mut World, blocks_current: bool) -> u64 {
    let n = w.pairs.len();
    // Results and scratch keep their buffers from earlier steps.
    w.detections.resize_with(n, Default::default);
    w.cache.detect.resize_with(n, Default::default);
    let view = SurfaceView::new(&w.objects, &w.cache.grids);
    let phyxel_grids = &w.cache.grids.phyxel;
    // Without a render surface only the force carriers' contacts are used: the
    // other surfels are not tested (a million-surfel sphere on 20k phyxels has one
    // carrier in four or five surfels).
    let render = w.render_contacts;
    let current = blocks_current;
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
    w.detections
        .par_iter_mut()
        .zip(w.cache.detect.par_iter_mut())
        .zip(w.pairs.par_iter())
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
    for sg in &mut w.cache.grids.surface {
        sg.depth = 0.0;
    }
    for d in &w.detections {
        // Over the force carriers, whether or not the others were tested, so that
        // writing frames does not change the reported depth.
        let carrier = |k: usize| {
            let c = &w.objects[k].force_carrier;
            move |s: u32| c[s as usize]
        };
        let depth = d.max_depth_of(carrier(d.a), carrier(d.b));
        w.record.max_penetration = w.record.max_penetration.max(depth);
        for k in [d.a, d.b] {
            let sg = &mut w.cache.grids.surface[k];
            sg.depth = sg.depth.max(depth);
        }
    }
    w.detections.iter().map(|d| d.candidates as u64).sum()
}

/// Colliding surfels moved onto the contact surface Φ (paper §6).
#[inline(never)] // a named frame in flamegraphs
fn contact_surface(w: &mut World) -> u64 {
    if w.pairs_in_order {
        return super::in_order::contact_in_order(w);
    }
    let touching = BumpVec::from_iter_in(
        w.detections
            .iter()
            .filter(|d| !d.a_in_b.is_empty() || !d.b_in_a.is_empty()),
        &w.cache.arena,
    );
    w.patches.resize_with(touching.len(), Default::default);
    w.cache.patch.resize_with(touching.len(), Default::default);
    let view = SurfaceView::new(&w.objects, &w.cache.grids);
    let dt = w.dt;
    w.patches
        .par_iter_mut()
        .zip(w.cache.patch.par_iter_mut())
        .zip(touching.par_iter())
        .for_each(|((patch, scratch), d)| {
            let p = view.params(d.a, d.b, dt);
            contact::contact_surface(d, &view.pair(d.a, d.b), &p, scratch, patch);
        });
    w.patches.iter().map(|p| p.surfels.len() as u64).sum()
}

/// Even, hole-free resampling of each contact surface for the render surface and, with
/// `World::resampled_forces`, as the contact surfels the forces act on; skipped when
/// neither needs it.
#[inline(never)] // a named frame in flamegraphs
fn resample(w: &mut World) -> u64 {
    if !(w.render_contacts || w.resampled_forces) {
        return 0;
    }
    if w.pairs_in_order {
        // Done pair by pair in the contact-surface phase.
        return w.patches.iter().map(|p| p.render.len() as u64).sum();
    }
    let view = SurfaceView::new(&w.objects, &w.cache.grids);
    let dt = w.dt;
    let on_resampled = w.resampled_forces;
    w.patches.par_iter_mut().for_each(|patch| {
        let p = view.params(patch.a, patch.b, dt);
        let pair = view.pair(patch.a, patch.b);
        contact::resample(patch, &pair, &p);
        if on_resampled {
            contact::anchor(&mut patch.render, &patch.surfels, &pair, &p);
            patch.surfels.clone_from(&patch.render);
        }
    });
    w.patches.iter().map(|p| p.render.len() as u64).sum()
}

/// Penalty and friction forces on the contact surfels (paper §7). Returns the
/// contact surfels forced and, of those, the ones whose pair has friction.
#[inline(never)] // a named frame in flamegraphs
fn forces(w: &mut World) -> u64 {
    let view = SurfaceView::new(&w.objects, &w.cache.grids);
    let dt = w.dt;
    let on_resampled = w.resampled_forces;
    let with_friction: u64 = w
        .patches
        .par_iter_mut()
        .zip(w.cache.patch.par_iter_mut())
        .map(|(patch, scratch)| {
            let mut p = view.params(patch.a, patch.b, dt);
            if on_resampled {
                // Resampled Φ has the surfel spacing, whatever the carriers'.
                p.force_spacing = p.spacing;
            }
            contact::forces(patch, &p, scratch);
            if p.friction > 0.0 {
                patch.surfels.len() as u64
            } else {
                0
            }
        })
        .sum();
    w.record.friction_work += with_friction;
    w.patches.iter().map(|p| p.surfels.len() as u64).sum()
}

/// Contact forces spread onto the phyxels of moving objects (their grids were built
/// this step with the surfel grids); they act at the next step. Parallel over
/// objects: each object takes its patches in patch order, so the sums do not depend
/// on the thread count. The patches of pairs in an implicit solve become its contact
/// springs instead ([`crate::solver::springs`]), which apply their force in the solve.
#[inline(never)] // a named frame in flamegraphs
fn distribute(w: &mut World) -> u64 {
    let n = w.objects.len();
    w.cache.distribute.resize_with(n, Default::default);
    {
        let c = &mut w.cache;
        let in_solve = BumpVec::from_iter_in(
            w.patches
                .iter()
                .map(|p| w.objects[p.a].contact_in_solve(&w.objects[p.b])),
            &c.arena,
        );
        let in_solve = &in_solve[..];
        let (patches, grids) = (&w.patches, &c.grids.phyxel);
        w.objects
            .par_iter_mut()
            .zip(c.distribute.par_iter_mut())
            .enumerate()
            .filter(|(_, (o, _))| !o.is_static())
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
    }
    let c = &mut w.cache;
    c.solver.renew_springs(
        &mut w.springs,
        &w.patches,
        &w.objects,
        &c.grids.phyxel,
        w.dt,
    );
    0
}

/// Self-collision forces (objects with `self_collision`), then fracture of the objects
/// whose backend and material can break ([`crate::body::fracture`]); each split is
/// recorded in `record.splits`. Returns the work (phyxels checked): zero when no
/// object uses either feature.
#[inline(never)] // a named frame in flamegraphs
fn topology(w: &mut World) -> u64 {
    let mut work = 0;
    for o in w.objects.iter_mut().filter(|o| !o.is_static()) {
        if let Some(sc) = &mut o.self_collision {
            work += o.phyxels.len() as u64;
            sc.apply(&mut o.phyxels, &o.material, w.dt);
        }
    }
    if !w.objects.iter().any(fracture::may_fracture) {
        return work;
    }
    // Each object that may break counts its components (a spanning-tree check
    // unless the tree broke: crate::body::connectivity), in parallel over objects.
    let (checked, breaking) = w
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
        return work;
    }
    // A body that has gone non-finite falls apart in the component count; it is
    // left whole for the end-of-step check to report (its pieces could not be built).
    let finite = |o: &Object| {
        [&o.phyxels.pos, &o.surfels.pos, &o.surfels.normal]
            .iter()
            .all(|c| c.first_non_finite().is_none())
    };
    let broken: Vec<(usize, Components)> = (0..w.objects.len())
        .filter(|&k| {
            let o = &w.objects[k];
            fracture::may_fracture(o) && o.connectivity.count() > 1 && finite(o)
        })
        .map(|k| (k, w.objects[k].connectivity.components()))
        .collect();
    // Pieces: the first takes the broken object's place (other objects keep their
    // indices, so static objects keep their grids), the others are appended.
    let mut objects: Vec<Option<Object>> = std::mem::take(&mut w.objects)
        .into_iter()
        .map(Some)
        .collect();
    let mut appended = Vec::new();
    for (k, comps) in broken {
        let o = objects[k].take().expect("each object splits once per step");
        match fracture::split(o, &comps, w.steps, &mut w.next_id) {
            Ok((pieces, event)) => {
                let mut pieces = pieces.into_iter();
                objects[k] = pieces.next();
                appended.extend(pieces);
                w.record.splits.push(event);
            }
            Err(o) => objects[k] = Some(*o),
        }
    }
    w.objects = objects.into_iter().flatten().collect();
    w.objects.extend(appended);
    // This step's detections and patches index the old objects' surfels.
    w.detections.clear();
    w.patches.clear();
    w.springs.clear();
    work
}
