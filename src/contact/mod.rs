//! Contact handling (Keiser et al. 2004, §6–7): the contact surface Φ between two
//! intersecting objects, its resampling, penalty and friction forces on the contact
//! surfels, and their distribution to the phyxels.

pub mod brent;
pub mod detect;
pub mod implicit;
pub mod params;

use crate::body::columns::{LANES, lane_mask, load8, store8};
use crate::body::phyxels::Phyxels;
use crate::body::surfels::Surfels;
use crate::contact::brent::brent;
use crate::contact::detect::{Colliding, PairDetection};
use crate::contact::implicit::{ImplicitSurface, NearHits, SurfaceSample};
use crate::dynamics::kernel::poly6_shape;
use crate::dynamics::mls::sym_eigen;
use crate::spatial::grid::Grid;
use glam::{DMat3, Vec3};
use rayon::prelude::*;
use wide::f32x8;

/// Phyxels a contact force spreads over at least (paper §7.3: k = 6).
pub const MIN_DISTRIBUTION_PHYXELS: usize = 6;
/// Friction regularisation speed (m/s): below it Coulomb friction is viscous
/// (`μ F_n v_t / FRICTION_SLIP_SPEED`). Explicit integration of that stiff viscous term
/// does not hold a sticking contact to this speed times `F_t/(μ F_n)`: a block on the 20°
/// `incline` (μ = 0.5, where that bound is 0.07 mm/s) creeps at 0.24–0.35 mm/s at
/// dt = 0.1 ms, in proportion to dt (docs/ACCURACY.md, "Known limits").
pub const FRICTION_SLIP_SPEED: f32 = 1.0e-4;

/// A surfel on the contact surface Φ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSurfel {
    pub pos: Vec3,
    /// Unit normal of Φ, pointing from object a into object b.
    pub normal: Vec3,
    /// The object whose colliding surfel it came from (`a` or `b`); inserted surfels
    /// belong to `a`.
    pub object: usize,
    /// Area of Φ it stands for (m²).
    pub area: f32,
    /// Contact force on object a (N); object b receives the opposite.
    pub force: Vec3,
    /// Where the colliding surfel's segment meets the original surfaces of a and b (the
    /// surfel and its projection onto the other surface): the ends of `d₁` and `d₂`.
    /// `pos` where Φ lies outside that object (its surface is not displaced there), and
    /// for inserted render surfels.
    pub anchor_a: Vec3,
    pub anchor_b: Vec3,
    /// Velocity of surface a relative to surface b at the anchors (m/s).
    pub velocity: Vec3,
}

/// The contact surface of one pair and its forces.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContactPatch {
    pub a: usize,
    pub b: usize,
    /// The colliding surfels of both objects moved onto Φ: they carry the forces.
    pub surfels: Vec<ContactSurfel>,
    /// Φ resampled evenly for the render surface (empty unless frames are written).
    pub render: Vec<ContactSurfel>,
    /// Colliding surfels dropped because the root left the intersection volume.
    pub dropped: usize,
    /// Colliding surfels that are not force carriers (not moved onto Φ; 0 unless every
    /// surfel was tested: `World::render_contacts`).
    pub not_carriers: usize,
}

/// Contact-response constants of one pair, from the two materials.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactParams {
    /// Surface weights λ = Young's modulus (paper §6), normalised to sum 1.
    pub lambda_a: f32,
    pub lambda_b: f32,
    /// Penalty spring stiffness per area (N/m³).
    pub stiffness: f32,
    /// Penalty damping per area (N·s/m³).
    pub damping: f32,
    /// Coulomb friction coefficient.
    pub friction: f32,
    /// Target spacing of contact surfels (m).
    pub spacing: f32,
    /// Spacing of the denser side's force-carrying contact surfels (m, ≥ `spacing`;
    /// equal to it when neither side is thinned): the support of their area estimate.
    pub force_spacing: f32,
}

/// The two implicit surfaces and the surfels of a pair.
#[derive(Clone, Copy)]
pub struct PairSurfaces<'a> {
    pub a: ImplicitSurface<'a>,
    pub b: ImplicitSurface<'a>,
    pub surfels_a: &'a Surfels,
    pub surfels_b: &'a Surfels,
    /// Which surfels of a and b carry contact forces.
    pub carriers_a: &'a [bool],
    pub carriers_b: &'a [bool],
}

impl PairSurfaces<'_> {
    /// `F(x) = λ_a f_a(x) − λ_b f_b(x)` (paper eq. 3).
    fn contact_function(&self, p: &ContactParams, x: Vec3) -> Option<f32> {
        Some(p.lambda_a * self.a.sample(x)?.f - p.lambda_b * self.b.sample(x)?.f)
    }

    /// Is `x` in the intersection volume (inside both, to `tol`)?
    fn in_volume(&self, x: Vec3, tol: f32) -> bool {
        matches!((self.a.sample(x), self.b.sample(x)), (Some(sa), Some(sb)) if sa.f <= tol && sb.f <= tol)
    }

    /// Normal of Φ at `x`, from a into b: the gradient of F, `λ_a n_a − λ_b n_b`
    /// normalised (so Φ against a much stiffer body takes that body's normal).
    fn normal(&self, x: Vec3, p: &ContactParams) -> Option<Vec3> {
        (p.lambda_a * self.a.sample(x)?.normal - p.lambda_b * self.b.sample(x)?.normal)
            .try_normalize()
    }
}

/// One side of the segment field at a point: `f` and its normal.
#[derive(Clone, Copy, Debug, Default)]
struct Side {
    f: f32,
    normal: Vec3,
}

/// `f_a`, `f_b` along one colliding surfel's segment: the implicit surfaces where a
/// surfel kernel reaches, else the first-order extension `n·(x − p)` of the signed
/// distance from the segment's anchor point p on that surface. Deep inside an overlap the
/// truncated implicit surface is undefined anyway, and the extension saves a k-nearest
/// search per evaluation (docs/ARCHITECTURE.md).
struct SegmentField<'a, 'b> {
    s: &'a PairSurfaces<'b>,
    anchor_a: (Vec3, Vec3),
    anchor_b: (Vec3, Vec3),
    /// The segment's start and its own surface's `sample_near` there (already taken
    /// for the anchor's normal); `from_a` says which surface that is.
    start: Vec3,
    start_own: Option<SurfaceSample>,
    from_a: bool,
    /// The colliding surfel, whose detection sampled the other surface at the start and
    /// at the projection.
    colliding: &'a Colliding,
    /// Each side's last kernel query, for Brent's next evaluation close by.
    kept_a: NearHits,
    kept_b: NearHits,
}

impl SegmentField<'_, '_> {
    fn side((p, n): (Vec3, Vec3), near: Option<SurfaceSample>, x: Vec3) -> Side {
        match near {
            Some(s) => Side {
                f: s.f,
                normal: s.normal,
            },
            None => Side {
                f: n.dot(x - p),
                normal: n,
            },
        }
    }

    /// `sample_near` of surface a (`on_a`) or b at `x`, reusing the start's and
    /// detection's samples and that side's last query.
    fn near(&mut self, on_a: bool, x: Vec3) -> Option<SurfaceSample> {
        let s = self.s;
        let (surface, kept) = if on_a {
            (&s.a, &mut self.kept_a)
        } else {
            (&s.b, &mut self.kept_b)
        };
        let own = on_a == self.from_a;
        match (own, x == self.start, x == self.colliding.projection) {
            (true, true, _) => self.start_own,
            (false, true, _) => self.colliding.near_surfel,
            (false, false, true) => self.colliding.near_projection,
            _ => surface.sample_near_kept(x, kept),
        }
    }

    fn f_a(&mut self, x: Vec3) -> Side {
        let near = self.near(true, x);
        Self::side(self.anchor_a, near, x)
    }

    fn f_b(&mut self, x: Vec3) -> Side {
        let near = self.near(false, x);
        Self::side(self.anchor_b, near, x)
    }
}

/// Most field evaluations remembered per segment (Brent's two brackets and 40 steps).
const SEGMENT_EVALUATIONS: usize = 42;

/// Moves every colliding surfel onto Φ: the root of F on the segment from the surfel to
/// its projection onto the other surface, by Brent's method; surfels whose root leaves
/// the intersection volume are dropped (paper §6). The root's samples are taken from
/// Brent's evaluations, not recomputed.
pub fn contact_surface(
    det: &PairDetection,
    s: &PairSurfaces<'_>,
    p: &ContactParams,
    scratch: &mut PatchScratch,
    patch: &mut ContactPatch,
) {
    let tol = 0.05 * p.spacing;
    // `own` is the surface the colliding surfel lies on, `other` the one it is inside;
    // the anchors are the surfel and its projection, with their surfaces' normals.
    let place = |c: &Colliding, own: &Surfels, from_a: bool, object: usize| {
        let start = own.pos.get(c.surfel as usize);
        let own_surface = if from_a { &s.a } else { &s.b };
        let start_own = own_surface.sample_near(start);
        let own_normal = own_surface.sample_given(start, start_own)?.normal;
        let (anchor_a, anchor_b) = if from_a {
            ((start, own_normal), (c.projection, c.normal))
        } else {
            ((c.projection, c.normal), (start, own_normal))
        };
        let mut field = SegmentField {
            s,
            anchor_a,
            anchor_b,
            start,
            start_own,
            from_a,
            colliding: c,
            kept_a: NearHits::default(),
            kept_b: NearHits::default(),
        };
        let seg = c.projection - start;
        let len = seg.length();
        // The segment's end is the projection itself (not `start + seg`, which may round
        // off it), so detection's sample there is reused.
        let at = |t: f32| {
            if t == 1.0 {
                c.projection
            } else {
                start + t * seg
            }
        };
        let (x, a, b) = if len < 1e-4 * p.spacing {
            (start, field.f_a(start), field.f_b(start))
        } else {
            let mut seen = [(0.0f32, Side::default(), Side::default()); SEGMENT_EVALUATIONS];
            let mut n_seen = 0;
            let t = brent(
                |t| {
                    let x = at(t);
                    let (a, b) = (field.f_a(x), field.f_b(x));
                    if n_seen < SEGMENT_EVALUATIONS {
                        seen[n_seen] = (t, a, b);
                        n_seen += 1;
                    }
                    // `F(x) = λ_a f_a(x) − λ_b f_b(x)` (paper eq. 3).
                    Some(p.lambda_a * a.f - p.lambda_b * b.f)
                },
                0.0,
                1.0,
                1e-3 * p.spacing / len,
                40,
            )?;
            let x = at(t);
            match seen[..n_seen].iter().find(|e| e.0 == t) {
                Some(&(_, a, b)) => (x, a, b),
                None => (x, field.f_a(x), field.f_b(x)),
            }
        };
        if a.f > tol || b.f > tol {
            return None;
        }
        // The surfel's own velocity, and the other surface's nearest surfel's.
        let v_own = own.vel.get(c.surfel as usize);
        let (other_surfels, other_surface) = if from_a {
            (s.surfels_b, &s.b)
        } else {
            (s.surfels_a, &s.a)
        };
        let v_other = other_surface
            .nearest(c.projection)
            .map_or(Vec3::ZERO, |(k, _)| other_surfels.vel.get(k));
        Some(ContactSurfel {
            pos: x,
            normal: (p.lambda_a * a.normal - p.lambda_b * b.normal).try_normalize()?,
            object,
            area: 0.0,
            force: Vec3::ZERO,
            anchor_a: if a.f <= 0.0 { anchor_a.0 } else { x },
            anchor_b: if b.f <= 0.0 { anchor_b.0 } else { x },
            velocity: if from_a {
                v_own - v_other
            } else {
                v_other - v_own
            },
        })
    };
    let n_a = det.a_in_b.len();
    let placed = &mut scratch.placed;
    placed.clear();
    placed.resize(n_a + det.b_in_a.len(), None);
    placed.par_iter_mut().enumerate().for_each(|(k, slot)| {
        *slot = if k < n_a {
            let c = &det.a_in_b[k];
            s.carriers_a[c.surfel as usize]
                .then(|| place(c, s.surfels_a, true, det.a))
                .flatten()
        } else {
            let c = &det.b_in_a[k - n_a];
            s.carriers_b[c.surfel as usize]
                .then(|| place(c, s.surfels_b, false, det.b))
                .flatten()
        };
    });
    patch.a = det.a;
    patch.b = det.b;
    patch.surfels.clear();
    patch.surfels.extend(placed.iter().flatten());
    patch.render.clear();
    patch.not_carriers = det
        .a_in_b
        .iter()
        .filter(|c| !s.carriers_a[c.surfel as usize])
        .count()
        + det
            .b_in_a
            .iter()
            .filter(|c| !s.carriers_b[c.surfel as usize])
            .count();
    patch.dropped = placed.len() - patch.surfels.len() - patch.not_carriers;
}

/// Scratch of one pair's contact phases, kept between steps so that the step does not
/// allocate once the buffers have grown to the contact's size.
#[derive(Clone, Debug, Default)]
pub struct PatchScratch {
    placed: Vec<Option<ContactSurfel>>,
    grid: Grid,
    density: Vec<f32>,
}

/// Scratch of [`distribute`]: the phyxels near one contact surfel, and the force
/// columns in the phyxel grid's sorted order (padded by `LANES − 1`); kept between
/// steps, so the step does not allocate.
#[derive(Clone, Debug, Default)]
pub struct DistributeScratch {
    near: Vec<(usize, f32)>,
    knn: Vec<(usize, f32)>,
    force: [Vec<f32>; 3],
    /// The lane groups of one surfel's query and their weights.
    lanes: Vec<(usize, f32x8)>,
}

/// Even, hole-free sampling of Φ for the render surface (after Witkin–Heckbert, as in
/// the paper's §6): deletion of surfels closer than half the spacing, insertion where a
/// tangent neighbourhood is empty, one relaxation pass with reprojection onto Φ, and
/// normals by PCA of the local neighbourhood (smallest eigenvector).
///
/// The forces stay on the unresampled contact surfels: which surfels deletion and
/// insertion keep changes discontinuously from step to step, and forces on them would
/// make a resting contact jitter, while a colliding surfel enters and leaves the
/// contact with zero penetration, so forces on those are continuous in time.
pub fn resample(patch: &mut ContactPatch, s: &PairSurfaces<'_>, p: &ContactParams) {
    patch.render.clear();
    if patch.surfels.is_empty() {
        return;
    }
    let h = p.spacing;
    let mut render = patch.surfels.clone();
    thin(&mut render, 0.5 * h);
    fill_holes(&mut render, patch.a, s, p);
    relax(&mut render, s, p);
    pca_normals(&mut render, 2.0 * h);
    patch.render = render;
}

fn grid_of(surfels: &[ContactSurfel], cell: f32) -> Grid {
    Grid::build(surfels.iter().map(|c| c.pos), cell)
}

/// Deletes surfels with an earlier kept surfel within `r` (deterministic Poisson-disk).
fn thin(surfels: &mut Vec<ContactSurfel>, r: f32) {
    let grid = grid_of(surfels, r);
    let mut keep = vec![true; surfels.len()];
    for i in 0..surfels.len() {
        let mut crowded = false;
        grid.for_each_within(surfels[i].pos, r, |j, _| crowded |= j < i && keep[j]);
        keep[i] = !crowded;
    }
    let mut k = 0;
    surfels.retain(|_| {
        k += 1;
        keep[k - 1]
    });
}

/// Inserts a surfel on Φ where one of six tangent directions of an existing surfel
/// has no surfel within 0.6 spacing, if that point lies in the intersection volume.
fn fill_holes(
    surfels: &mut Vec<ContactSurfel>,
    object: usize,
    s: &PairSurfaces<'_>,
    p: &ContactParams,
) {
    let h = p.spacing;
    let grid = grid_of(surfels, h);
    let mut added: Vec<ContactSurfel> = Vec::new();
    for c in surfels.iter() {
        let t1 = c.normal.any_orthonormal_vector();
        let t2 = c.normal.cross(t1);
        for k in 0..6 {
            let ang = k as f32 * std::f32::consts::FRAC_PI_3;
            let guess = c.pos + h * (ang.cos() * t1 + ang.sin() * t2);
            let mut empty = true;
            grid.for_each_within(guess, 0.6 * h, |_, _| empty = false);
            if !empty || added.iter().any(|a| a.pos.distance(guess) < 0.6 * h) {
                continue;
            }
            if let Some(x) = reproject(guess, c.normal, s, p)
                && s.in_volume(x, 0.05 * h)
                && let Some(n) = s.normal(x, p)
            {
                added.push(ContactSurfel {
                    pos: x,
                    normal: n,
                    object,
                    area: 0.0,
                    force: Vec3::ZERO,
                    anchor_a: x,
                    anchor_b: x,
                    velocity: Vec3::ZERO,
                });
            }
        }
    }
    surfels.extend(added);
}

/// The root of F along `x + t n`, |t| ≤ one spacing.
fn reproject(x: Vec3, n: Vec3, s: &PairSurfaces<'_>, p: &ContactParams) -> Option<Vec3> {
    let h = p.spacing;
    let t = brent(|t| s.contact_function(p, x + t * n), -h, h, 1e-3 * h, 40)?;
    Some(x + t * n)
}

/// One relaxation pass: tangential repulsion from neighbours closer than the spacing,
/// then reprojection onto Φ (kept in place where reprojection fails).
fn relax(surfels: &mut [ContactSurfel], s: &PairSurfaces<'_>, p: &ContactParams) {
    let h = p.spacing;
    let grid = grid_of(surfels, h);
    let moved: Vec<Vec3> = surfels
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let mut push = Vec3::ZERO;
            grid.for_each_within(c.pos, h, |j, d2| {
                if j != i {
                    let d = c.pos - surfels[j].pos;
                    let r = d2.sqrt().max(1e-9);
                    push += d / r * (h - r);
                }
            });
            let tangential = push - push.dot(c.normal) * c.normal;
            let guess = c.pos + 0.25 * tangential;
            match reproject(guess, c.normal, s, p) {
                Some(x) if s.in_volume(x, 0.05 * h) => x,
                _ => c.pos,
            }
        })
        .collect();
    for (c, x) in surfels.iter_mut().zip(moved) {
        c.pos = x;
    }
}

/// Normals by PCA of the neighbourhood within `r`, oriented like the current normal.
fn pca_normals(surfels: &mut [ContactSurfel], r: f32) {
    let grid = grid_of(surfels, r);
    let normals: Vec<Vec3> = surfels
        .par_iter()
        .map(|c| {
            let (mut sum, mut n) = (Vec3::ZERO, 0);
            let mut pts = Vec::new();
            grid.for_each_within(c.pos, r, |j, _| {
                sum += surfels[j].pos;
                n += 1;
                pts.push(surfels[j].pos);
            });
            if n < 3 {
                return c.normal;
            }
            let mean = sum / n as f32;
            let mut cov = DMat3::ZERO;
            for q in pts {
                let d = (q - mean).as_dvec3();
                cov += DMat3::from_cols(d * d.x, d * d.y, d * d.z);
            }
            let (vals, vecs) = sym_eigen(cov);
            let k = (0..3)
                .min_by(|&x, &y| vals[x].total_cmp(&vals[y]))
                .unwrap_or(0);
            let e = vecs.col(k).as_vec3();
            // A flat, well-spread neighbourhood defines the plane; otherwise keep Φ's normal.
            if vals[k] > 0.1 * vals[(k + 1) % 3].min(vals[(k + 2) % 3]) {
                return c.normal;
            }
            if e.dot(c.normal) < 0.0 { -e } else { e }
        })
        .collect();
    for (c, n) in surfels.iter_mut().zip(normals) {
        c.normal = n;
    }
}

/// Area each contact surfel stands for: `1 / Σ_j W(|x_i − x_j|)` with the normalised
/// 2-D poly6 kernel of support 2 spacings (a kernel density estimate of surfels per m²,
/// exact for any uniform sampling, unlike a k-nearest radius).
///
/// The kernel is evaluated as `4/(π h²) · (1 − r²/h²)³`: written as `4/(π h⁸) · (h² −
/// r²)³` its `h⁸` left f32's range for spacings below about 8 µm (every area 0, so no
/// contact force) or above about 30 km (areas infinite, forces NaN).
pub fn areas(surfels: &mut [ContactSurfel], spacing: f32, scratch: &mut PatchScratch) {
    let hh = 2.0 * spacing;
    let norm = 4.0 / (std::f32::consts::PI * (hh * hh));
    let PatchScratch { grid, density, .. } = scratch;
    grid.rebuild(surfels.iter().map(|c| c.pos), hh);
    density.clear();
    density.resize(surfels.len(), 0.0);
    let grid = &*grid;
    let inv_hh2 = f32x8::splat(1.0 / (hh * hh));
    // Eight neighbours at a time over the grid's lane groups (lanes off the mask weigh 0).
    density.par_iter_mut().enumerate().for_each(|(i, rho)| {
        let mut sum = f32x8::ZERO;
        grid.for_each_lanes_within(surfels[i].pos, hh, |_, mask, d2| {
            let q = f32x8::ONE - d2 * inv_hh2;
            sum += lane_mask(mask).select(q * q * q, f32x8::ZERO);
        });
        *rho = norm * sum.reduce_add();
    });
    for (c, &rho) in surfels.iter_mut().zip(density.iter()) {
        c.area = 1.0 / rho;
    }
}

/// Penalty and friction force on each contact surfel (paper eqs. 3–7), with Newton's
/// third law and the factor ½, times the surfel's area.
///
/// `d₁ = s₁ − s_c` runs from Φ to the original surface of object a, `d₂` likewise for b.
/// `s₁`, `s₂` are the ends of the colliding surfel's segment (the surfel and its
/// orthogonal projection onto the other surface): `s_c` lies on that segment, which is
/// the other surface's normal line, so its end there is `s_c`'s orthogonal projection,
/// and the surfel's own end is too up to the (second-order) angle between the two
/// normals, which the projection onto Φ's normal below removes to first order. This is
/// more accurate than the paper's closest surfel when the penetration is below a surfel
/// spacing, and costs no implicit-surface sample (docs/ARCHITECTURE.md).
/// Only the component of `d` along Φ's normal is kept: a frictionless contact must push
/// along the contact normal, and the tangential part of `d` is sampling noise (rim
/// surfels of a curved body) that would make a resting body drift; friction alone acts
/// tangentially.
pub fn forces(patch: &mut ContactPatch, p: &ContactParams, scratch: &mut PatchScratch) {
    areas(&mut patch.surfels, p.force_spacing, scratch);
    let one_side = |d: Vec3, n: Vec3, v_rel: Vec3| -> Vec3 {
        let d = d.dot(n) * n;
        let len = d.length();
        if len <= 0.0 {
            return Vec3::ZERO;
        }
        let dn = d / len;
        let approach = v_rel.dot(dn);
        // Spring plus dashpot, clamped to push only: a separating contact must not
        // stick through its damping term.
        let pen = -(p.stiffness * len + p.damping * approach).max(0.0) * dn;
        if p.friction > 0.0 {
            let vt = v_rel - approach * dn;
            let speed = vt.length();
            let scale = p.friction * pen.length() / speed.max(FRICTION_SLIP_SPEED);
            pen - scale * vt
        } else {
            pen
        }
    };
    patch.surfels.par_iter_mut().for_each(|c| {
        let fa = one_side(c.anchor_a - c.pos, c.normal, c.velocity);
        let fb = one_side(c.anchor_b - c.pos, c.normal, -c.velocity);
        c.force = 0.5 * (fa - fb) * c.area;
    });
}

/// Spreads each contact surfel's force over the phyxels of one object with the poly6
/// kernel of support `h` (twice the influence radius), widened to the
/// [`MIN_DISTRIBUTION_PHYXELS`] nearest where fewer lie within `h`, normalised so the
/// phyxel forces sum exactly to the surfel force (paper eqs. 8–9), with a rotational
/// field that makes them act at the surfel (`Couple`: no moment about it, so a pair's
/// forces conserve angular momentum too). `sign` is +1 for
/// object a, −1 for b. The forces act at the next step.
///
/// Eight phyxels at a time over the grid's sorted lanes (`Grid::for_each_lanes_within`):
/// one query per surfel gives its lane groups and their weights, whose sum normalises;
/// the surfel's share then goes to force columns kept in the grid's order, so the adds
/// are contiguous lane stores instead of scattered writes; the columns go to the
/// phyxels once at the end. [`distribute_reference`] is the scalar
/// version (tests and benches).
pub fn distribute(
    surfels: &[ContactSurfel],
    sign: f32,
    phyxels: &mut Phyxels,
    grid: &Grid,
    h: f32,
    scratch: &mut DistributeScratch,
) {
    let order = grid.sorted();
    for col in scratch.force.iter_mut() {
        col.clear();
        col.resize(order.len() + LANES - 1, 0.0);
    }
    let inv_h2 = f32x8::splat(1.0 / (h * h));
    // Poly6 shape `(1 − r²/h²)³` of the lanes in `mask` (0 elsewhere, padding included).
    let weights = |mask: u32, d2: f32x8| {
        let q = f32x8::ONE - d2 * inv_h2;
        let within = lane_mask(mask) & q.simd_gt(f32x8::ZERO);
        within.select(q * q * q, f32x8::ZERO)
    };
    let DistributeScratch {
        near,
        knn,
        force: [fx, fy, fz],
        lanes,
    } = scratch;
    let [px, py, pz] = grid.sorted_points();
    for c in surfels {
        // One grid query: the weighted lane groups are kept for the adds, and the
        // weights' moments about the surfel are summed on the way.
        lanes.clear();
        let (mut total, mut count) = (f32x8::ZERO, 0);
        let (cx, cy, cz) = (
            f32x8::splat(c.pos.x),
            f32x8::splat(c.pos.y),
            f32x8::splat(c.pos.z),
        );
        let mut m1 = [f32x8::ZERO; 3];
        let mut m2 = [f32x8::ZERO; 6];
        grid.for_each_lanes_within(c.pos, h, |at, mask, d2| {
            let w = weights(mask, d2);
            total += w;
            count += mask.count_ones() as usize;
            lanes.push((at, w));
            let y = [load8(px, at) - cx, load8(py, at) - cy, load8(pz, at) - cz];
            let wy = [w * y[0], w * y[1], w * y[2]];
            for k in 0..3 {
                m1[k] += wy[k];
            }
            m2[0] += wy[0] * y[0];
            m2[1] += wy[1] * y[1];
            m2[2] += wy[2] * y[2];
            m2[3] += wy[0] * y[1];
            m2[4] += wy[0] * y[2];
            m2[5] += wy[1] * y[2];
        });
        if count < MIN_DISTRIBUTION_PHYXELS {
            // Too few phyxels within h: the scalar path widens to the nearest ones.
            distribute_one::<false>(c, sign, phyxels, grid, h, near, knn);
            continue;
        }
        let total = total.reduce_add();
        if total <= 0.0 {
            continue;
        }
        let f = sign * c.force;
        let Couple { centroid, omega } = Couple::at_surfel(
            f,
            c.pos,
            total,
            m1.map(|m| m.reduce_add()),
            m2.map(|m| m.reduce_add()),
        );
        // Each phyxel's share `ŵ (f + ω × y)`, y = x − (s_c + d).
        let inv = f32x8::splat(1.0 / total);
        let [ax, ay, az] = f.to_array().map(f32x8::splat);
        let [ox, oy, oz] = omega.to_array().map(f32x8::splat);
        let [rx, ry, rz] = centroid.to_array().map(f32x8::splat);
        for &(at, w) in lanes.iter() {
            let y = [load8(px, at) - rx, load8(py, at) - ry, load8(pz, at) - rz];
            let w = w * inv;
            let g = [
                ax + oy * y[2] - oz * y[1],
                ay + oz * y[0] - ox * y[2],
                az + ox * y[1] - oy * y[0],
            ];
            for (col, s) in [(&mut *fx, g[0]), (&mut *fy, g[1]), (&mut *fz, g[2])] {
                let v = load8(col, at) + w * s;
                store8(col, at, v);
            }
        }
    }
    let [fx, fy, fz] = &scratch.force;
    for (k, &i) in order.iter().enumerate() {
        phyxels
            .force
            .add(i as usize, Vec3::new(fx[k], fy[k], fz[k]));
    }
}

/// Scalar reference of [`distribute`]: the same weights, one phyxel at a time, found by
/// the scalar grid query ([`Grid::for_each_within_scalar`]) and written straight to the
/// phyxels; no lanes anywhere.
pub fn distribute_reference(
    surfels: &[ContactSurfel],
    sign: f32,
    phyxels: &mut Phyxels,
    grid: &Grid,
    h: f32,
    scratch: &mut DistributeScratch,
) {
    let DistributeScratch { near, knn, .. } = scratch;
    for c in surfels {
        distribute_one::<true>(c, sign, phyxels, grid, h, near, knn);
    }
}

/// One contact surfel's force onto the phyxels, one phyxel at a time (see
/// [`distribute`]), over the scalar or the lane grid query.
fn distribute_one<const SCALAR_QUERY: bool>(
    c: &ContactSurfel,
    sign: f32,
    phyxels: &mut Phyxels,
    grid: &Grid,
    h: f32,
    near: &mut Vec<(usize, f32)>,
    knn: &mut Vec<(usize, f32)>,
) {
    near.clear();
    if SCALAR_QUERY {
        grid.for_each_within_scalar(c.pos, h, |i, d2| near.push((i, d2)));
    } else {
        grid.for_each_within(c.pos, h, |i, d2| near.push((i, d2)));
    }
    let mut support = h;
    let widened = near.len() < MIN_DISTRIBUTION_PHYXELS;
    if widened {
        grid.k_nearest(c.pos, MIN_DISTRIBUTION_PHYXELS, knn);
        support = knn.last().map_or(h, |e| e.1.sqrt() * 1.001 + 1e-9);
        near.clear();
        near.extend_from_slice(knn);
    }
    // Weights in place of the squared distances; the grid's order is deterministic.
    let mut total = 0.0f32;
    let mut m1 = [0.0f32; 3];
    let mut m2 = [0.0f32; 6];
    for e in near.iter_mut() {
        e.1 = poly6_shape(e.1, support);
        total += e.1;
        let (w, y) = (e.1, phyxels.pos.get(e.0) - c.pos);
        let wy = w * y;
        for k in 0..3 {
            m1[k] += wy[k];
        }
        m2[0] += wy.x * y.x;
        m2[1] += wy.y * y.y;
        m2[2] += wy.z * y.z;
        m2[3] += wy.x * y.y;
        m2[4] += wy.x * y.z;
        m2[5] += wy.y * y.z;
    }
    if total <= 0.0 {
        return;
    }
    let f = sign * c.force;
    let Couple { centroid, omega } = if widened {
        // A surfel beyond reach of all but a few phyxels keeps eq. 8's spread: the
        // moment about it would take lever forces many times `f` on those few.
        Couple {
            centroid: c.pos,
            omega: Vec3::ZERO,
        }
    } else {
        Couple::at_surfel(f, c.pos, total, m1, m2)
    };
    for &(i, w) in near.iter() {
        let y = phyxels.pos.get(i) - centroid;
        phyxels.force.add(i, (w / total) * (f + omega.cross(y)));
    }
}

/// A contact surfel's force `f` split over phyxels so that it acts at the surfel `s_c`:
/// phyxel `i` (normalised weight `ŵᵢ`, offset `yᵢ = xᵢ − s_c`) takes
/// `ŵᵢ (f + ω × (yᵢ − d))`.
///
/// Eq. 8 alone (`ŵᵢ f`) sums to `f` but applies it at the weighted phyxel centroid
/// `s_c + d`, `d = Σ ŵᵢ yᵢ`, which lies inside the object, about half a phyxel spacing
/// behind Φ: the two objects of a pair then take `f` and `−f` at points a spacing or so
/// apart, a couple `(d_a − d_b) × f` that changes the pair's angular momentum (with
/// friction, ~10% of it in one off-centre collision of `two-spheres`). The rotational
/// field `ω × (yᵢ − d)` adds no force, and `ω = −I⁻¹ (d × f)` (`I` the weights' inertia
/// tensor about the centroid) cancels the moment about `s_c`, so the pair's forces are
/// equal, opposite and collinear (Newton's third law in its strong form): linear and
/// angular momentum are both conserved. The rotational part is taken about the
/// centroid `s_c + d`, where its terms are smallest (f32 round-off). A surfel with
/// fewer than [`MIN_DISTRIBUTION_PHYXELS`] phyxels within reach (the widened k-nearest
/// spread: a body sampled by a few phyxels, a surfel far outside) keeps eq. 8's spread.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Couple {
    /// The weighted phyxel centroid `s_c + d` (m).
    centroid: Vec3,
    /// `ω` (N/m).
    omega: Vec3,
}

impl Couple {
    /// From the surfel's force `f`, the weights' sum `total`, their first moments
    /// `Σ wᵢ yᵢ` and second moments `Σ wᵢ yᵢ yᵢᵀ` (xx, yy, zz, xy, xz, yz) about `s_c`.
    /// Directions in which the phyxels cannot take a moment (collinear phyxels: an
    /// eigenvalue of `I` below 1e-3 of the largest) are left uncorrected.
    fn at_surfel(f: Vec3, at: Vec3, total: f32, m1: [f32; 3], m2: [f32; 6]) -> Self {
        let t = total as f64;
        let d = glam::DVec3::from_array(m1.map(|m| m as f64 / t));
        let s = m2.map(|m| m as f64 / t);
        // Covariance about the centroid, and the inertia tensor `tr C · 1 − C`.
        let cov = DMat3::from_cols_array(&[
            s[0] - d.x * d.x,
            s[3] - d.x * d.y,
            s[4] - d.x * d.z,
            s[3] - d.x * d.y,
            s[1] - d.y * d.y,
            s[5] - d.y * d.z,
            s[4] - d.x * d.z,
            s[5] - d.y * d.z,
            s[2] - d.z * d.z,
        ]);
        let inertia = DMat3::from_diagonal(glam::DVec3::splat(
            cov.x_axis.x + cov.y_axis.y + cov.z_axis.z,
        )) - cov;
        let f64 = f.as_dvec3();
        let rhs = -d.cross(f64);
        let scale = inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z;
        let centroid = (at.as_dvec3() + d).as_vec3();
        if scale.is_nan() || scale <= 0.0 || !rhs.is_finite() {
            return Self {
                centroid,
                omega: Vec3::ZERO,
            };
        }
        let det = inertia.determinant();
        // `det ≥ 1e-3 tr³` bounds the smallest eigenvalue above 1e-3 of the largest
        // (`λ_min ≥ det / λ_max²`); a plane of phyxels gives 0.03, a ball 0.04.
        let omega = if det > 1e-3 * scale.powi(3) {
            inertia.inverse() * rhs
        } else {
            // Nearly collinear phyxels (or weights dominated by one or two): a
            // pseudo-inverse over the directions they span.
            let (vals, vecs) = sym_eigen(inertia);
            let top = vals.iter().fold(0.0f64, |m, &v| m.max(v));
            (0..3)
                .filter(|&k| vals[k] > 1e-3 * top)
                .map(|k| vecs.col(k) * (vecs.col(k).dot(rhs) / vals[k]))
                .sum()
        };
        Self {
            centroid,
            omega: omega.as_vec3(),
        }
    }
}
