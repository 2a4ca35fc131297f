//! Phyxels: the volume samples that carry mass and are moved by a dynamics backend.

use crate::columns::{Vec3s, scalar_column};
use crate::spatial::grid::Grid;
use glam::Vec3;

/// Number of nearest phyxels whose mean distance defines the spacing `r_i`
/// (Müller et al. 2004, section 4.3).
pub const SPACING_NEIGHBOURS: usize = 10;

/// Influence radius `h_i = SUPPORT_FACTOR · r_i` (Müller et al. 2004 use 3).
pub const SUPPORT_FACTOR: f32 = 2.0;

/// SoA columns of an object's phyxels.
///
/// `force` holds external forces (contact, user loads) for the next step; the backend
/// consumes and clears it. `fixed` phyxels are anchored: no backend moves them.
///
/// The columns are padded for the SIMD loops: `mass` and `fixed` (like the `Vec3s`
/// columns) hold `columns::padded_len(n)` entries, the padding with zero mass. Build
/// phyxels with [`Phyxels::at_rest`] (or `gather`) rather than by hand; an object's
/// phyxel set is fixed once it is bound to surfels (`Object::new`).
#[derive(Clone, Debug, Default)]
pub struct Phyxels {
    /// Current positions (m), moved by the backend.
    pub pos: Vec3s,
    /// Rest positions (m): the displacement `u = pos − rest` strains the material.
    pub rest: Vec3s,
    /// Velocities (m/s).
    pub vel: Vec3s,
    /// External force for the next step (N).
    pub force: Vec3s,
    /// Mass (kg).
    pub mass: Vec<f32>,
    /// Rest volume each phyxel stands for (m³).
    pub volume: Vec<f32>,
    /// Spacing `r_i`: mean distance to the nearest phyxels at rest (m).
    pub spacing: Vec<f32>,
    /// Influence radius `h_i` (support of the phyxel's kernel, m).
    pub radius: Vec<f32>,
    /// Anchored phyxels (1) are never moved.
    pub fixed: Vec<u8>,
    /// What the last position update lost to f32 rounding (m), added to the next one
    /// (compensated summation): a step's motion can be far below a position's ulp (a
    /// stiff body's small stable dt, or a body far from the origin), and plain `x + v·dt`
    /// then moves it too little or not at all. Zero at rest; setting `pos` by hand may
    /// leave it as it is (it is below half an ulp).
    pub pos_carry: Vec3s,
}

impl Phyxels {
    /// Checks the columns' lengths against the phyxel count (see
    /// [`columns::check_lengths`](crate::columns::check_lengths)) and, with `values`,
    /// that masses, volumes, spacings and influence radii are finite and > 0 (a
    /// zero-mass phyxel never moves, a zero radius reaches nothing). `Err` names the
    /// column.
    pub fn check(&self, values: bool) -> Result<(), String> {
        let n = self.len();
        crate::columns::check_lengths(
            n,
            &[
                ("pos", &self.pos),
                ("rest", &self.rest),
                ("vel", &self.vel),
                ("force", &self.force),
                ("pos_carry", &self.pos_carry),
            ],
            &[
                ("mass", self.mass.len()),
                ("volume", self.volume.len()),
                ("spacing", self.spacing.len()),
                ("radius", self.radius.len()),
                ("fixed", self.fixed.len()),
            ],
        )?;
        if values {
            use crate::columns::check_positive;
            check_positive("mass", &self.mass[..n])?;
            check_positive("volume", &self.volume[..n])?;
            check_positive("spacing", &self.spacing[..n])?;
            check_positive("radius", &self.radius[..n])?;
        }
        Ok(())
    }

    /// Phyxels at rest at `points`, each standing for `cell_volume` of material of `density`.
    ///
    /// Mass is `density · cell_volume`, so the total mass is the sampled volume times the
    /// density (the lattice cell is the honest volume of a lattice sample; see
    /// docs/ARCHITECTURE.md). Spacing and influence radius follow Müller et al. 2004.
    pub fn at_rest(points: &[Vec3], cell_volume: f32, density: f32) -> Self {
        let n = points.len();
        let rest = Vec3s::from_points(points);
        let spacing = rest_spacing(points, cell_volume.cbrt());
        let radius = scalar_column(spacing.iter().map(|r| SUPPORT_FACTOR * r));
        Self {
            pos: rest.clone(),
            rest,
            vel: Vec3s::zeros(n),
            force: Vec3s::zeros(n),
            mass: scalar_column(std::iter::repeat_n(density * cell_volume, n)),
            volume: scalar_column(std::iter::repeat_n(cell_volume, n)),
            spacing: scalar_column(spacing.into_iter()),
            radius,
            fixed: vec![0; crate::columns::padded_len(n)],
            pos_carry: Vec3s::zeros(n),
        }
    }

    /// The same phyxels, each standing for its own volume of `density` material (a
    /// quadrature's volumes: [`crate::body::shape::quadrature`]); mass follows.
    ///
    /// # Panics
    /// If `volumes` does not hold one volume per phyxel.
    pub fn with_volumes(mut self, volumes: &[f32], density: f32) -> Self {
        assert_eq!(volumes.len(), self.len(), "one volume per phyxel");
        for (i, &v) in volumes.iter().enumerate() {
            self.volume[i] = v;
            self.mass[i] = density * v;
        }
        self
    }

    /// The phyxels at `idx`, in that order, every column copied (a fragment's phyxels).
    pub fn gather(&self, idx: &[usize]) -> Self {
        let col = |c: &[f32]| scalar_column(idx.iter().map(|&i| c[i]));
        let mut fixed: Vec<u8> = idx.iter().map(|&i| self.fixed[i]).collect();
        fixed.resize(crate::columns::padded_len(idx.len()), 0);
        Self {
            pos: self.pos.gather(idx),
            rest: self.rest.gather(idx),
            vel: self.vel.gather(idx),
            force: self.force.gather(idx),
            mass: col(&self.mass),
            volume: col(&self.volume),
            spacing: col(&self.spacing),
            radius: col(&self.radius),
            fixed,
            pos_carry: self.pos_carry.gather(idx),
        }
    }

    /// Number of phyxels.
    #[inline]
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Total mass (kg).
    pub fn total_mass(&self) -> f64 {
        self.mass[..self.len()].iter().map(|&m| m as f64).sum()
    }

    /// Linear momentum Σ m v (kg·m/s), accumulated in f64.
    pub fn momentum(&self) -> [f64; 3] {
        let mut p = [0.0f64; 3];
        for i in 0..self.len() {
            let m = self.mass[i] as f64;
            p[0] += m * self.vel.x[i] as f64;
            p[1] += m * self.vel.y[i] as f64;
            p[2] += m * self.vel.z[i] as f64;
        }
        p
    }

    /// Centre of mass (m).
    pub fn centre_of_mass(&self) -> [f64; 3] {
        let mut c = [0.0f64; 3];
        let mut m_sum = 0.0;
        for i in 0..self.len() {
            let m = self.mass[i] as f64;
            m_sum += m;
            c[0] += m * self.pos.x[i] as f64;
            c[1] += m * self.pos.y[i] as f64;
            c[2] += m * self.pos.z[i] as f64;
        }
        if m_sum > 0.0 {
            c.iter_mut().for_each(|v| *v /= m_sum);
        }
        c
    }

    /// Kinetic energy ½ Σ m |v|² (J), in f64 (|v|² of a finite f32 velocity can
    /// overflow f32).
    pub fn kinetic_energy(&self) -> f64 {
        (0..self.len())
            .map(|i| 0.5 * self.mass[i] as f64 * self.vel.get(i).as_dvec3().length_squared())
            .sum()
    }

    /// True when positions and velocities are all finite.
    pub fn all_finite(&self) -> bool {
        self.pos.all_finite() && self.vel.all_finite()
    }

    /// A grid over the rest positions with cells of the largest influence radius.
    pub fn rest_grid(&self) -> Grid {
        let h = self.radius[..self.len()]
            .iter()
            .fold(0.0f32, |a, &b| a.max(b));
        Grid::build(self.rest.iter(), if h > 0.0 { h } else { 1.0 })
    }
}

/// `r_i`: mean distance to the [`SPACING_NEIGHBOURS`] nearest other points; `fallback`
/// when a point has no neighbour at all (a single phyxel).
fn rest_spacing(points: &[Vec3], fallback: f32) -> Vec<f32> {
    let grid = Grid::build(points.iter().copied(), fallback.max(1e-9) * 2.0);
    let mut knn = Vec::new();
    points
        .iter()
        .map(|&p| {
            grid.k_nearest(p, SPACING_NEIGHBOURS + 1, &mut knn);
            let d: Vec<f32> = knn.iter().skip(1).map(|&(_, d2)| d2.sqrt()).collect();
            if d.is_empty() {
                fallback
            } else {
                d.iter().sum::<f32>() / d.len() as f32
            }
        })
        .collect()
}
