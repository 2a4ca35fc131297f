//! Self-collision (Keiser et al. 2004, §8): an object stores the phyxel pairs within the
//! influence radius at rest; two phyxels that come closer than their spacing without
//! being rest neighbours are pushed apart by an equal and opposite penalty force
//! ([`SelfCollision`]).

use crate::columns::Vec3s;
use crate::material::Material;
use crate::points::phyxels::Phyxels;
use crate::spatial::grid::Grid;
use glam::Vec3;
use rayon::prelude::*;

/// Penalty stiffness of the self-collision force, in units of `contact_stiffness · E · r`
/// (Young's modulus times phyxel spacing: the stiffness of a bar of cross-section r² and
/// length r, scaled by the material's contact stiffness). Capped by
/// [`SELF_CONTACT_MAX_RATE`]: a folding body hits itself at speed and must stop within
/// about one spacing.
pub const SELF_CONTACT_STIFFNESS: f32 = 25.0;

/// Largest `ω dt` of one self-collision spring (`ω = √(k/m̄)`): a phyxel pressed by a few
/// such springs stays well inside the explicit limit `ω dt < 2`.
pub const SELF_CONTACT_MAX_RATE: f32 = 0.3;

/// Self-collision of one object (paper §8): the rest neighbours within the influence
/// radius, as sorted rows, and the grid of the current positions (kept, so that a step
/// allocates nothing).
#[derive(Clone, Debug, Default)]
pub struct SelfCollision {
    offsets: Vec<u32>,
    neighbours: Vec<u32>,
    grid: Grid,
}

impl SelfCollision {
    /// The pairs of `phyxels` closer than `max(h_i, h_j)` at rest.
    pub fn new(phyxels: &Phyxels) -> Self {
        let n = phyxels.len();
        let grid = phyxels.rest_grid();
        let rows: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .map(|i| {
                let xi = phyxels.rest.get(i);
                let mut row = Vec::new();
                grid.for_each_within(xi, grid.cell(), |j, d2| {
                    let h = phyxels.radius[i].max(phyxels.radius[j]);
                    if j != i && d2 < h * h {
                        row.push(j as u32);
                    }
                });
                row.sort_unstable();
                row
            })
            .collect();
        let mut s = Self {
            offsets: vec![0],
            neighbours: Vec::new(),
            grid: Grid::default(),
        };
        for row in rows {
            s.neighbours.extend_from_slice(&row);
            s.offsets.push(s.neighbours.len() as u32);
        }
        s
    }

    /// True when `i` and `j` were within the influence radius at rest.
    pub fn rest_neighbours(&self, i: usize, j: usize) -> bool {
        let row = &self.neighbours[self.offsets[i] as usize..self.offsets[i + 1] as usize];
        row.binary_search(&(j as u32)).is_ok()
    }

    /// Adds the penalty forces to `phyxels.force` (they act in the next step): pairs
    /// `i`, `j` closer than the mean of their spacings `r̄` that are not rest neighbours
    /// get `f_i = −f_j = (k (r̄ − d) − c v_n) n`, `n` from j to i, `v_n` the approach
    /// speed, `k` = min([`SELF_CONTACT_STIFFNESS`] · `contact_stiffness` · `E r̄`,
    /// `m̄ (`[`SELF_CONTACT_MAX_RATE`]`/dt)²`), `c` = `2 ζ √(k m̄/2)` with ζ = the
    /// material's `contact_damping` (at most 1). Returns the pairs pushed.
    ///
    /// Each phyxel sums its own pairs (a pair is evaluated from both ends), so phyxels
    /// run in parallel without a shared scatter, in an order fixed by the grid alone.
    /// The two ends compute the same force to the bit with opposite signs (the
    /// difference, distance and approach speed only change sign), so Newton's third law
    /// holds pair by pair.
    pub fn apply(&mut self, phyxels: &mut Phyxels, material: &Material, dt: f32) -> u64 {
        let n = phyxels.len();
        if n < 2 {
            return 0;
        }
        let r_max = phyxels.spacing[..n].iter().fold(0.0f32, |a, &b| a.max(b));
        self.grid.rebuild_columns(&phyxels.pos, r_max.max(1e-6));
        let zeta = material.contact_damping.clamp(0.0, 1.0);
        let k_material = SELF_CONTACT_STIFFNESS * material.contact_stiffness * material.young;
        let rate2 = (SELF_CONTACT_MAX_RATE / dt.max(f32::MIN_POSITIVE)).powi(2);
        let this = &*self;
        let Phyxels {
            pos,
            vel,
            mass,
            spacing,
            force,
            ..
        } = phyxels;
        let (pos, vel) = (&*pos, &*vel);
        let Vec3s { x, y, z, .. } = force;
        x[..n]
            .par_chunks_mut(SELF_CONTACT_CHUNK)
            .zip(y[..n].par_chunks_mut(SELF_CONTACT_CHUNK))
            .zip(z[..n].par_chunks_mut(SELF_CONTACT_CHUNK))
            .enumerate()
            .map(|(c, ((fx, fy), fz))| {
                let mut pairs = 0;
                for (k, ((fx, fy), fz)) in fx.iter_mut().zip(fy).zip(fz).enumerate() {
                    let i = c * SELF_CONTACT_CHUNK + k;
                    let (xi, vi) = (pos.get(i), vel.get(i));
                    let mut f = Vec3::ZERO;
                    this.grid.for_each_within(xi, r_max, |j, d2| {
                        let rbar = 0.5 * (spacing[i] + spacing[j]);
                        if j == i || d2 >= rbar * rbar || this.rest_neighbours(i, j) {
                            return;
                        }
                        let d = d2.sqrt();
                        let dir = if d > 0.0 {
                            (xi - pos.get(j)) / d
                        } else if i < j {
                            Vec3::Y
                        } else {
                            -Vec3::Y
                        };
                        let m = 0.5 * (mass[i] + mass[j]);
                        let k = (k_material * rbar).min(m * rate2);
                        let c = 2.0 * zeta * (k * 0.5 * m).sqrt();
                        let approach = (vi - vel.get(j)).dot(dir);
                        let push = (k * (rbar - d) - c * approach).max(0.0);
                        if push > 0.0 {
                            f += dir * push;
                            pairs += u64::from(i < j);
                        }
                    });
                    (*fx, *fy, *fz) = (*fx + f.x, *fy + f.y, *fz + f.z);
                }
                pairs
            })
            .sum()
    }
}

/// Phyxels per parallel task of [`SelfCollision::apply`].
const SELF_CONTACT_CHUNK: usize = 64;
