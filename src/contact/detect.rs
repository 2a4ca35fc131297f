//! Colliding surfels (Keiser et al. 2004, §5, eq. 2): the surfels of one object that lie
//! in the pair's intersection box and inside the other object's implicit surface.

use crate::contact::field::{FarHint, SurfaceField, SurfaceSample};
use crate::points::surfels::Surfels;
use crate::spatial::broad_phase::{Aabb, Pair, points_in_blocks};
use crate::spatial::grid::Grid;
use glam::Vec3;
use rayon::prelude::*;

/// A surfel of one object found inside another.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Colliding {
    /// Index of the surfel in its object.
    pub surfel: u32,
    /// Its projection onto the other object's surface.
    pub projection: Vec3,
    /// The other surface's normal at the projection.
    pub normal: Vec3,
    /// Penetration depth `−(x − x_proj)·n(x_proj)` (m): > 0 inside; for a gap
    /// ([`Candidates::margin`]) minus the gap, ≤ 0.
    pub depth: f32,
    /// The other surface's `sample_near` at the surfel and at the projection (`None`
    /// where no kernel reaches): the contact surface's root search starts from them.
    pub near_surfel: Option<SurfaceSample>,
    pub near_projection: Option<SurfaceSample>,
}

/// Detection result of one pair, kept for the contact-surface phase.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PairDetection {
    /// Object indices, `a < b`.
    pub a: usize,
    pub b: usize,
    /// Surfels of `a` inside `b`, and of `b` inside `a`, in surfel order.
    pub a_in_b: Vec<Colliding>,
    pub b_in_a: Vec<Colliding>,
    /// Surfels of `a` outside `b` within the pair's margin, and of `b` outside `a`
    /// ([`Candidates::margin`]; empty without one), in surfel order.
    pub a_near_b: Vec<Colliding>,
    pub b_near_a: Vec<Colliding>,
    /// Candidates tested (surfels of either object in the intersection box).
    pub candidates: usize,
}

impl PairDetection {
    /// Largest penetration depth in this pair (m), 0 without colliding surfels.
    pub fn max_depth(&self) -> f32 {
        self.max_depth_of(|_| true, |_| true)
    }

    /// Largest penetration depth of the colliding surfels `s` of a with `of_a(s)` and
    /// of b with `of_b(s)` (m), 0 without any.
    pub fn max_depth_of(&self, of_a: impl Fn(u32) -> bool, of_b: impl Fn(u32) -> bool) -> f32 {
        let a = self.a_in_b.iter().filter(|c| of_a(c.surfel));
        let b = self.b_in_a.iter().filter(|c| of_b(c.surfel));
        a.chain(b).fold(0.0f32, |m, c| m.max(c.depth))
    }
}

/// A candidate whose implicit function `f` exceeds this fraction of the kernel reach is
/// outside without projecting it (eq. 2 agrees: in every built-in scene, no candidate
/// with `f > 0` is inside; `tests/contact/detect.rs` checks the margin against the full test).
pub const OUTSIDE_FRACTION: f32 = 0.05;
/// Candidates per rayon task (a few hundred candidates per side at the paper's size
/// still split over both cores).
const CHUNK: usize = 64;

/// The other object's volume, for candidates far from its surface: a point farther than
/// the kernels reach from every surfel is inside exactly when a phyxel lies within
/// `reach` of it (phyxels sit at least half a spacing inside the surface, and every
/// interior point is within `√3/2` lattice spacings of one).
#[derive(Clone, Copy)]
pub struct Volume<'a> {
    pub phyxels: &'a Grid,
    /// Mean phyxel spacing (m).
    pub reach: f32,
}

impl Volume<'_> {
    fn contains(&self, x: Vec3) -> bool {
        self.phyxels.any_within(x, self.reach)
    }
}

/// Scratch of one side of a pair's detection, kept between steps so that the step does
/// not allocate once it has grown to the contact's size.
#[derive(Clone, Debug, Default)]
pub struct DetectScratch {
    candidates: Vec<u32>,
    found: Vec<Option<Colliding>>,
    /// Per surfel, the far-field search radius of its last deep projection: a deep
    /// surfel is about as deep one step later, so its next search starts there.
    far_hints: Vec<FarHint>,
    /// `far_hints` of this step's candidates, in candidate order.
    hints: Vec<FarHint>,
    /// The pair and surfel count `far_hints` belong to.
    owner: (usize, usize, usize),
}

/// The surfels one side of a pair may test against the other side's surface.
#[derive(Clone, Copy, Debug)]
pub struct Candidates<'a> {
    /// Every surfel of the object.
    pub surfels: &'a Surfels,
    /// The boxes of the surfels' blocks when they bound the current positions
    /// ([`crate::body::advect::SurfelBinding::block_boxes`]): the candidate scan skips the blocks
    /// outside the pair's box ([`points_in_blocks`]; the same candidates).
    pub blocks: Option<&'a [Aabb]>,
    /// When set, the surfels `s` with `only[s]` false are not tested (the force carriers
    /// when no render surface needs the others: see `World::render_contacts`).
    pub only: Option<&'a [bool]>,
    /// Surfels outside the other object by at most this gap (m) are found too, as gaps:
    /// an implicit solve takes them as springs that push once the step closes their
    /// gap ([`crate::solver::springs::speculate`]). 0: none.
    pub margin: f32,
}

/// The surfels of `side` in `pair.bounds` that are inside `other`, in surfel order,
/// written to `out`, and those outside it within `side.margin`, written to `gaps`;
/// returns the number of candidates tested. Candidates far from
/// `other`'s surface are classified by `volume` alone (one grid query) and projected only
/// when inside (deep penetration); candidates near it whose `f` is clearly positive
/// ([`OUTSIDE_FRACTION`]) are outside without a projection.
pub fn colliding_surfels(
    side: Candidates<'_>,
    other: &SurfaceField<'_>,
    volume: &Volume<'_>,
    pair: &Pair,
    scratch: &mut DetectScratch,
    out: &mut Vec<Colliding>,
    gaps: &mut Vec<Colliding>,
) -> usize {
    let Candidates {
        surfels,
        blocks,
        only,
        margin,
    } = side;
    let DetectScratch {
        candidates,
        found,
        far_hints,
        hints,
        owner,
    } = scratch;
    let outside = (OUTSIDE_FRACTION * other.reach()).max(margin);
    candidates.clear();
    points_in_blocks(&surfels.pos, blocks, &pair.bounds, candidates);
    if let Some(only) = only {
        candidates.retain(|&s| only[s as usize]);
    }
    // Hints of another pair or object would still give exact results, only slower.
    let this = (pair.a, pair.b, surfels.len());
    if *owner != this {
        *owner = this;
        far_hints.clear();
        far_hints.resize(surfels.len(), FarHint::default());
    }
    hints.clear();
    hints.extend(candidates.iter().map(|&s| far_hints[s as usize]));
    found.clear();
    found.resize(candidates.len(), None);
    found
        .par_chunks_mut(CHUNK)
        .zip(hints.par_chunks_mut(CHUNK))
        .zip(candidates.par_chunks(CHUNK))
        .for_each(|((slots, hints), chunk)| {
            for ((slot, hint), &s) in slots.iter_mut().zip(hints).zip(chunk) {
                let x = surfels.pos.get(s as usize);
                let near = other.sample_near(x);
                let clearly_outside = near.is_some_and(|s| s.f > outside);
                *slot = if clearly_outside || (near.is_none() && !volume.contains(x)) {
                    None
                } else {
                    other.inside_hinted(x, near, hint).and_then(|(inside, p)| {
                        let gap = !inside && p.signed_distance <= margin && margin > 0.0;
                        (inside || gap).then_some(Colliding {
                            surfel: s,
                            projection: p.point,
                            normal: p.normal,
                            depth: -p.signed_distance,
                            near_surfel: near,
                            near_projection: p.near,
                        })
                    })
                };
            }
        });
    for (&s, &h) in candidates.iter().zip(hints.iter()) {
        far_hints[s as usize] = h;
    }
    out.clear();
    out.extend(found.iter().flatten().filter(|c| c.depth > 0.0));
    gaps.clear();
    gaps.extend(found.iter().flatten().filter(|c| c.depth <= 0.0));
    candidates.len()
}
