//! Surfels: oriented surface disks that follow the phyxels.

use crate::columns::{Vec3s, scalar_column};
use glam::Vec3;

/// SoA columns of an object's surfels.
#[derive(Clone, Debug, Default)]
pub struct Surfels {
    /// Current disk centres (m), written by the advection each step.
    pub pos: Vec3s,
    /// Rest positions (m): the advection moves each surfel from here with its phyxels.
    pub rest: Vec3s,
    /// Current unit normals (outward), written by the advection.
    pub normal: Vec3s,
    /// Rest unit normals (outward).
    pub rest_normal: Vec3s,
    /// Current velocities (m/s), written by the advection (friction and damping read
    /// them).
    pub vel: Vec3s,
    /// Disk radius (m).
    pub radius: Vec<f32>,
}

impl Surfels {
    /// Checks the columns' lengths against the surfel count (see
    /// [`columns::check_lengths`](crate::columns::check_lengths)) and, with `values`,
    /// that the disk radii are finite and > 0 (a zero radius makes every kernel weight
    /// zero: the object's surface would vanish from detection). `Err` names the column.
    pub fn check(&self, values: bool) -> Result<(), String> {
        let n = self.len();
        crate::columns::check_lengths(
            n,
            &[
                ("pos", &self.pos),
                ("rest", &self.rest),
                ("normal", &self.normal),
                ("rest_normal", &self.rest_normal),
                ("vel", &self.vel),
            ],
            &[("radius", self.radius.len())],
        )?;
        if values {
            crate::columns::check_positive("radius", &self.radius[..n])?;
        }
        Ok(())
    }

    /// Surfels at rest.
    ///
    /// # Panics
    ///
    /// If `points`, `normals` and `radii` differ in length.
    pub fn at_rest(points: &[Vec3], normals: &[Vec3], radii: &[f32]) -> Self {
        assert_eq!(
            points.len(),
            normals.len(),
            "Surfels::at_rest: as many normals as points"
        );
        assert_eq!(
            points.len(),
            radii.len(),
            "Surfels::at_rest: as many radii as points"
        );
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

    /// The surfels at `idx`, in that order, every column copied.
    pub fn gather(&self, idx: &[usize]) -> Self {
        Self {
            pos: self.pos.gather(idx),
            rest: self.rest.gather(idx),
            normal: self.normal.gather(idx),
            rest_normal: self.rest_normal.gather(idx),
            vel: self.vel.gather(idx),
            radius: scalar_column(idx.iter().map(|&i| self.radius[i])),
        }
    }

    /// These surfels followed by `more`'s (every column).
    pub fn concat(&self, more: &Surfels) -> Self {
        let (n, m) = (self.len(), more.len());
        let join = |a: &Vec3s, b: &Vec3s| {
            let mut p = a.to_vec();
            p.extend(b.iter());
            Vec3s::from_points(&p)
        };
        Self {
            pos: join(&self.pos, &more.pos),
            rest: join(&self.rest, &more.rest),
            normal: join(&self.normal, &more.normal),
            rest_normal: join(&self.rest_normal, &more.rest_normal),
            vel: join(&self.vel, &more.vel),
            radius: scalar_column(
                self.radius[..n]
                    .iter()
                    .chain(&more.radius[..m])
                    .copied()
                    .collect::<Vec<f32>>()
                    .into_iter(),
            ),
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
