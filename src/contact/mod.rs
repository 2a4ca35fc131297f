//! Contact handling (Keiser et al. 2004, §5–7): colliding surfels found against the
//! surface field of each object (§5, the paper's implicit surface: `field`, `detect`), the contact surface Φ between two intersecting
//! objects and its resampling (§6), penalty and friction forces on the contact surfels
//! and their distribution to the phyxels (§7). This module holds the types the phases
//! share: contact surfels, patches, the pair's surfaces and scratch.

/// Moved to [`crate::math::brent`].
pub mod brent {
    /// Moved to [`crate::math::brent::brent`].
    #[deprecated(note = "use phyxel::math::brent::brent")]
    pub fn brent(
        f: impl FnMut(f32) -> Option<f32>,
        a: f32,
        b: f32,
        tol: f32,
        max_iter: u32,
    ) -> Option<f32> {
        crate::math::brent::brent(f, a, b, tol, max_iter)
    }
}
pub mod detect;
pub(crate) mod distribute;
pub mod field;
mod forces;

/// Moved to [`field`] (the paper's implicit surface is the surface field `f`).
pub mod implicit {
    pub use super::field::{
        CUTOFF_SIGMAS, FAR_GRID_FACTOR, FAR_NEIGHBOURS, FarHint, MAX_PROJECTION_ITERATIONS,
        MAX_STEP_HALVINGS, NEAR_HITS, NEAR_HITS_SLACK, NearHits, PROJECTION_ROUNDOFF_EPS,
        PROJECTION_SLOPE_COS, PROJECTION_SLOPE_RANGE, PROJECTION_TOLERANCE, Projection,
        SIGMA_PER_RADIUS, SurfaceSample, SurfelRows, exp_neg, grid_cell, radius_range,
    };
    /// Renamed [`super::field::SurfaceField`].
    #[deprecated(note = "use phyxel::contact::field::SurfaceField")]
    pub type ImplicitSurface<'a> = super::field::SurfaceField<'a>;
}
pub mod params;
pub mod report;
mod resample;
pub mod stick;
mod surface;

pub use distribute::{DistributeScratch, MIN_DISTRIBUTION_PHYXELS, distribute};
pub use forces::{FRICTION_SLIP_SPEED, StickContext, areas, forces, keep_sticks};
pub use params::ContactParams;
pub use report::{ContactPoint, PatchTotals};
pub use resample::{anchor, resample};

/// Moved to [`Object::contact_in_solve`](crate::body::object::Object::contact_in_solve).
#[deprecated(note = "use Object::contact_in_solve")]
pub fn springs_apply(a: &crate::body::object::Object, b: &crate::body::object::Object) -> bool {
    a.contact_in_solve(b)
}
pub use surface::contact_surface;

use crate::columns::{LANES, lane_mask, load8, store8};
use crate::contact::detect::{Colliding, PairDetection};
use crate::contact::field::{NearHits, SurfaceField, SurfaceSample};
use crate::math::brent::brent;
use crate::math::kernel::poly6_shape;
use crate::math::linalg::sym_eigen;
use crate::points::phyxels::Phyxels;
use crate::points::surfels::Surfels;
use crate::spatial::grid::Grid;
use glam::{DMat3, Vec3};
use rayon::prelude::*;
use wide::f32x8;

/// A surfel on the contact surface Φ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSurfel {
    pub pos: Vec3,
    /// Unit normal of Φ, pointing from object a into object b.
    pub normal: Vec3,
    /// The object whose colliding surfel it came from (`a` or `b`); inserted surfels
    /// belong to `a`.
    pub object: usize,
    /// That colliding surfel's index in its object ([`NO_SURFEL`] for an inserted
    /// surfel): with the pair, it names the contact across steps.
    pub surfel: u32,
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
    /// The friction spring's elongation after the forces (m): surface a's tangential
    /// displacement against b since the contact last stuck ([`stick`]).
    pub stick: Vec3,
    /// The surfel spacing of Φ here over the pair's finest ([`ContactParams::spacing`]):
    /// 1, or more where a graded body's coarser level is in contact
    /// ([`local_scale`]); the area estimate's support follows it.
    pub scale: f32,
}

/// [`ContactSurfel::scale`] from the finer of the two surfaces' disk radii (m) where a
/// contact surfel lies: their spacing over the pair's `spacing`, or 1 below 1.5 (a
/// uniform pair's surfels are within rounding of it, and each graded level is twice the
/// next).
pub fn local_scale(radius_a: f32, radius_b: f32, spacing: f32) -> f32 {
    let ratio = radius_a.min(radius_b) * std::f32::consts::FRAC_PI_2.sqrt() / spacing;
    if ratio < 1.5 { 1.0 } else { ratio }
}

/// The surface area (m²) a force carrier of disk radius `radius` and rest normal
/// `rest_normal` stands for, on an object of carrier spacing `carrier` (m). The
/// samplers' disks cover the surface twice over (a surfel's spacing is `r √(π/2)`), so
/// a surfel stands for `π r² / 2`. Carriers thinned to one per cell of edge `carrier`
/// (finer surfels: [`crate::body::object::FORCE_CARRIER_SPACING`]) stand for their
/// cell's share of the surface, `carrier² / |n|₁`: a plane of unit normal n crosses
/// `|n|₁ / carrier²` cells of a cubic grid per m² (exact where surfels are much finer
/// than the cells, as at the sizes that thin).
pub fn carrier_area(radius: f32, rest_normal: Vec3, carrier: f32) -> f32 {
    let own = radius * radius * std::f32::consts::FRAC_PI_2;
    if carrier * carrier > own * 1.0002 {
        let l1 = rest_normal.abs().element_sum();
        carrier * carrier / l1.max(1.0)
    } else {
        own
    }
}

/// [`ContactSurfel::surfel`] of a surfel inserted by resampling (no colliding surfel).
pub const NO_SURFEL: u32 = u32::MAX;

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

/// The two surface fields and the surfels of a pair.
#[derive(Clone, Copy)]
pub struct PairSurfaces<'a> {
    pub a: SurfaceField<'a>,
    pub b: SurfaceField<'a>,
    pub surfels_a: &'a Surfels,
    pub surfels_b: &'a Surfels,
    /// Which surfels of a and b carry contact forces.
    pub carriers_a: &'a [bool],
    pub carriers_b: &'a [bool],
    /// Their carrier spacings (m; [`Object::carrier_spacing`](crate::body::object::Object::carrier_spacing)), for [`carrier_area`].
    pub carrier_spacing_a: f32,
    pub carrier_spacing_b: f32,
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

/// Scratch of one pair's contact phases, kept between steps so that the step does not
/// allocate once the buffers have grown to the contact's size.
#[derive(Clone, Debug, Default)]
pub struct PatchScratch {
    placed: Vec<Option<ContactSurfel>>,
    grid: Grid,
    density: Vec<f32>,
    /// [`areas`]' side column in the grid's lane order.
    side: Vec<f32>,
}
