//! Surfels: oriented surface disks that follow the phyxels.

use crate::columns::{Vec3s, scalar_column};
use glam::Vec3;

/// SoA columns of an object's surfels.
#[derive(Clone, Debug, Default)]
pub struct Surfels {
    pub pos: Vec3s,
    pub rest: Vec3s,
    pub normal: Vec3s,
    pub rest_normal: Vec3s,
    pub vel: Vec3s,
    /// Disk radius (m).
    pub radius: Vec<f32>,
}

impl Surfels {
    /// Surfels at rest.
    pub fn at_rest(points: &[Vec3], normals: &[Vec3], radii: &[f32]) -> Self {
        assert_eq!(points.len(), normals.len());
        assert_eq!(points.len(), radii.len());
        let rest = Vec3s::from_points(points);
        let rest_normal = Vec3s::from_points(normals);
        Self {
            pos: rest.clone(),
            rest,
            normal: rest_normal.clone(),
            rest_normal,
            vel: Vec3s::zeros(points.len()),
            radius: scalar_column(radii.iter().copied()),
        }
    }

    #[inline]
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// True when positions, normals and velocities are all finite.
    pub fn all_finite(&self) -> bool {
        self.pos.all_finite() && self.normal.all_finite() && self.vel.all_finite()
    }
}
