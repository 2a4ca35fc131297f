//! The scalar references of the SIMD kernels, in one place for tests and benches: each
//! computes what its kernel computes one point at a time, with no lanes, so that the
//! kernel can be checked against it (docs/PERFORMANCE.md, "Rules"). Not part of the API
//! (hidden from the docs; any release may change it).

use crate::backends::mls::MlsDynamics;
use crate::body::advect::SurfelBinding;
use crate::contact::field::SurfaceField;
use crate::contact::{ContactSurfel, DistributeScratch};
use crate::material::Material;
use crate::points::phyxels::Phyxels;
use crate::points::surfels::Surfels;
use crate::spatial::grid::Grid;
use glam::{Mat3, Vec3};

/// [`Grid::for_each_within`], one point at a time and in order.
pub fn for_each_within_scalar(grid: &Grid, x: Vec3, r: f32, f: impl FnMut(usize, f32)) {
    grid.for_each_within_scalar(x, r, f)
}

/// [`SurfaceField::weighted_sums`] with the scalar grid query and libm `exp`.
pub fn weighted_sums_scalar(field: &SurfaceField<'_>, x: Vec3) -> (f32, Vec3, Vec3) {
    field.weighted_sums_scalar(x)
}

/// [`crate::contact::distribute()`], one phyxel at a time.
pub fn distribute_reference(
    surfels: &[ContactSurfel],
    sign: f32,
    phyxels: &mut Phyxels,
    grid: &Grid,
    h: f32,
    scratch: &mut DistributeScratch,
) {
    crate::contact::distribute::distribute_reference(surfels, sign, phyxels, grid, h, scratch)
}

/// [`SurfelBinding::advect`] as the direct sum of Müller et al. (2004, §5).
pub fn advect_reference(
    binding: &SurfelBinding,
    surfels: &mut Surfels,
    phyxels: &Phyxels,
    grad: &[Mat3],
) {
    binding.advect_reference(surfels, phyxels, grad)
}

/// [`MlsDynamics::compute_forces`] per phyxel with glam matrices.
pub fn compute_forces_reference(
    mls: &mut MlsDynamics,
    phyxels: &Phyxels,
    material: &Material,
    dt: f32,
) {
    mls.compute_forces_reference(phyxels, material, dt)
}
