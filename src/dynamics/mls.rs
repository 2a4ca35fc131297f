//! Moving-least-squares estimate of the displacement gradient (Müller et al. 2004, §4.2).
//!
//! For phyxel i with rest neighbours j within its influence radius `h_i`:
//! moment matrix `A_i = Σ_j x_ij x_ijᵀ w_ij`, weights `d_j = A_i⁻¹ x_ij w_ij`,
//! `d_i = −Σ_j d_j`, and the gradient `∇u_i = Σ_j (u_j − u_i) d_jᵀ` — exact for affine
//! displacement fields wherever `A_i` has full rank. The stencil is built once at rest.

use crate::body::phyxels::Phyxels;
use crate::columns::Vec3s;
use crate::dynamics::kernel::poly6_shape;
use glam::{DMat3, DVec3, Mat3, Vec3};
use rayon::prelude::*;

/// Condition number above which a moment matrix counts as ill-conditioned; its smallest
/// eigen-directions are then left out of the inverse (pseudo-inverse) instead of
/// amplifying noise (coplanar or collinear neighbourhoods, too few neighbours).
pub const MAX_CONDITION: f64 = 1.0e4;

/// Polynomial basis of the MLS fit behind the gradient.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GradientBasis {
    /// Linear basis (Müller et al. 2004): exact for affine fields; near a free surface the
    /// one-sided neighbourhood biases the gradient of curved fields (bending comes out soft).
    Linear,
    /// Linear plus quadratic terms: also exact for quadratic fields, so bending near a
    /// surface is right. Same cost per step (only the rest stencil changes); falls back to
    /// linear where the neighbourhood cannot support a quadratic fit.
    #[default]
    Quadratic,
}

/// Precomputed MLS stencil of a phyxel set (compressed rows, one per phyxel).
#[derive(Clone, Debug, Default)]
pub struct MlsStencil {
    /// `offsets[i]..offsets[i + 1]` are phyxel i's neighbours.
    pub offsets: Vec<u32>,
    pub neighbours: Vec<u32>,
    /// `d_j` for each (i, j) entry.
    pub d: Vec<Vec3>,
    /// `d_i = −Σ_j d_j`.
    pub d_self: Vec<Vec3>,
    /// Phyxels whose moment matrix was rank-deficient or ill-conditioned.
    pub ill_conditioned: Vec<bool>,
}

impl MlsStencil {
    /// Builds the stencil from the rest positions and influence radii of `phyxels`.
    pub fn build(phyxels: &Phyxels) -> Self {
        Self::build_with(phyxels, GradientBasis::Linear)
    }

    /// Builds the stencil with the given fit basis.
    pub fn build_with(phyxels: &Phyxels, basis: GradientBasis) -> Self {
        let n = phyxels.len();
        let grid = phyxels.rest_grid();
        let rows: Vec<(Vec<u32>, Vec<Vec3>, Vec3, bool)> = (0..n)
            .into_par_iter()
            .map(|i| {
                let xi = phyxels.rest.get(i);
                let h = phyxels.radius[i];
                let mut nb: Vec<(u32, f32)> = Vec::new();
                grid.for_each_within(xi, h, |j, d2| {
                    if j != i {
                        nb.push((j as u32, d2));
                    }
                });
                nb.sort_unstable_by_key(|e| e.0);
                // The weights matter only up to a factor per row (`A⁻¹ x w` and the
                // quadratic fit do not change when all of a row's weights scale), so the
                // unnormalised poly6 shape: the normalised kernel's 1/h⁹ overflowed f32
                // below about 15 µm spacing, and every weight came out infinite.
                let mut a = DMat3::ZERO;
                for &(j, d2) in &nb {
                    let x = (phyxels.rest.get(j as usize) - xi).as_dvec3();
                    let w = poly6_shape(d2, h) as f64;
                    a += outer(x, x * w);
                }
                let (a_inv, ill) = pseudo_inverse(a);
                let offsets: Vec<(DVec3, f64)> = nb
                    .iter()
                    .map(|&(j, d2)| {
                        (
                            (phyxels.rest.get(j as usize) - xi).as_dvec3(),
                            poly6_shape(d2, h) as f64,
                        )
                    })
                    .collect();
                let quadratic = match basis {
                    GradientBasis::Quadratic if !ill => quadratic_weights(&offsets, h as f64),
                    _ => None,
                };
                let ds: Vec<Vec3> = quadratic.unwrap_or_else(|| {
                    offsets
                        .iter()
                        .map(|&(x, w)| (a_inv * (x * w)).as_vec3())
                        .collect()
                });
                let d_self = -ds.iter().copied().sum::<Vec3>();
                (nb.into_iter().map(|e| e.0).collect(), ds, d_self, ill)
            })
            .collect();
        let mut s = Self {
            offsets: Vec::with_capacity(n + 1),
            ..Default::default()
        };
        s.offsets.push(0);
        for (nb, ds, d_self, ill) in rows {
            s.neighbours.extend_from_slice(&nb);
            s.d.extend_from_slice(&ds);
            s.offsets.push(s.neighbours.len() as u32);
            s.d_self.push(d_self);
            s.ill_conditioned.push(ill);
        }
        s
    }

    /// Number of phyxels.
    pub fn len(&self) -> usize {
        self.d_self.len()
    }

    pub fn is_empty(&self) -> bool {
        self.d_self.is_empty()
    }

    /// Entry range of phyxel i.
    #[inline]
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i] as usize..self.offsets[i + 1] as usize
    }

    /// `∇u_i = Σ_j (u_j − u_i) d_jᵀ` of the field `u` (column b holds ∂u/∂x_b).
    #[inline]
    pub fn gradient_of(&self, i: usize, u: impl Fn(usize) -> Vec3) -> Mat3 {
        let ui = u(i);
        let mut g = Mat3::ZERO;
        for k in self.row(i) {
            let du = u(self.neighbours[k] as usize) - ui;
            let d = self.d[k];
            g.x_axis += du * d.x;
            g.y_axis += du * d.y;
            g.z_axis += du * d.z;
        }
        g
    }

    /// Displacement gradient of every phyxel from current and rest positions.
    pub fn displacement_gradients(&self, pos: &Vec3s, rest: &Vec3s, out: &mut [Mat3]) {
        out.par_iter_mut().enumerate().for_each(|(i, g)| {
            *g = self.gradient_of(i, |j| pos.get(j) - rest.get(j));
        });
    }

    /// Gradient of the field `u` (one `Vec3` per phyxel) at every phyxel. With `u` packed
    /// as one array a neighbour costs one 12-byte load instead of one from each of six
    /// SoA columns (the stencil's neighbours are scattered over the columns).
    pub fn gradients(&self, u: &[Vec3], out: &mut [Mat3]) {
        out.par_iter_mut().enumerate().for_each(|(i, g)| {
            *g = self.gradient_of(i, |j| u[j]);
        });
    }
}

/// Largest condition number accepted for the quadratic fit (in units scaled by h).
const MAX_CONDITION_QUADRATIC: f64 = 1.0e7;

/// Gradient weights `d_j` of the fit `u_j − u_i ≈ ∇u x_ij + ½ x_ijᵀ H x_ij` (9 unknowns
/// per component), or `None` when the neighbourhood cannot support it.
fn quadratic_weights(offsets: &[(DVec3, f64)], h: f64) -> Option<Vec<Vec3>> {
    if offsets.len() < 12 {
        return None;
    }
    // Offsets scaled by h so linear and quadratic terms are of one size.
    let basis = |x: DVec3| {
        let q = x / h;
        [
            q.x,
            q.y,
            q.z,
            q.x * q.x,
            q.y * q.y,
            q.z * q.z,
            q.x * q.y,
            q.y * q.z,
            q.z * q.x,
        ]
    };
    let mut m = [[0.0f64; 9]; 9];
    for &(x, w) in offsets {
        let p = basis(x);
        for r in 0..9 {
            for c in 0..9 {
                m[r][c] += w * p[r] * p[c];
            }
        }
    }
    let (vals, vecs) = jacobi_eigen(m);
    let lmax = vals.iter().fold(0.0f64, |a, &v| a.max(v.abs()));
    if lmax.is_nan() || lmax <= 0.0 || vals.iter().any(|&v| v < lmax / MAX_CONDITION_QUADRATIC) {
        return None;
    }
    // Rows 0..3 of M⁻¹ = V diag(1/λ) Vᵀ.
    let mut inv3 = [[0.0f64; 9]; 3];
    for r in 0..3 {
        for c in 0..9 {
            inv3[r][c] = (0..9).map(|k| vecs[r][k] * vecs[c][k] / vals[k]).sum();
        }
    }
    Some(
        offsets
            .iter()
            .map(|&(x, w)| {
                let p = basis(x);
                let d: [f64; 3] =
                    std::array::from_fn(|r| (0..9).map(|c| inv3[r][c] * p[c]).sum::<f64>() * w / h);
                Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32)
            })
            .collect(),
    )
}

/// Eigen-decomposition of a symmetric N×N matrix by cyclic Jacobi: eigenvalues and
/// eigenvectors (`vecs[row][k]` is component `row` of eigenvector k).
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix formulas
fn jacobi_eigen<const N: usize>(mut m: [[f64; N]; N]) -> ([f64; N], [[f64; N]; N]) {
    let mut v = [[0.0f64; N]; N];
    for (k, row) in v.iter_mut().enumerate() {
        row[k] = 1.0;
    }
    for _sweep in 0..60 {
        let mut off = 0.0;
        let mut diag = 0.0;
        for p in 0..N {
            diag += m[p][p] * m[p][p];
            for q in p + 1..N {
                off += m[p][q] * m[p][q];
            }
        }
        if off <= 1e-30 * diag.max(1e-300) {
            break;
        }
        for p in 0..N {
            for q in p + 1..N {
                if m[p][q].abs() < 1e-300 {
                    continue;
                }
                let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..N {
                    let (mkp, mkq) = (m[k][p], m[k][q]);
                    m[k][p] = c * mkp - s * mkq;
                    m[k][q] = s * mkp + c * mkq;
                }
                for k in 0..N {
                    let (mpk, mqk) = (m[p][k], m[q][k]);
                    m[p][k] = c * mpk - s * mqk;
                    m[q][k] = s * mpk + c * mqk;
                }
                for row in v.iter_mut() {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    (std::array::from_fn(|k| m[k][k]), v)
}

/// Cofactor matrix `[J₂×J₃, J₃×J₁, J₁×J₂]` (columns) = `det(J) J⁻ᵀ` = ∂det J/∂J:
/// the volume term's force direction and the normal transform without a division.
#[inline]
pub fn cofactor(j: Mat3) -> Mat3 {
    Mat3::from_cols(
        j.y_axis.cross(j.z_axis),
        j.z_axis.cross(j.x_axis),
        j.x_axis.cross(j.y_axis),
    )
}

#[inline]
fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Inverse of a symmetric positive semi-definite 3×3 matrix through its eigen-decomposition,
/// dropping eigen-directions below `λ_max / MAX_CONDITION`. Returns the (pseudo-)inverse
/// and whether anything was dropped.
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix formulas
pub fn pseudo_inverse(a: DMat3) -> (DMat3, bool) {
    let (vals, vecs) = sym_eigen(a);
    let lmax = vals.iter().fold(0.0f64, |m, &v| m.max(v.abs()));
    if lmax <= 0.0 || !lmax.is_finite() {
        return (DMat3::ZERO, true);
    }
    let mut inv = DMat3::ZERO;
    let mut ill = false;
    for k in 0..3 {
        if vals[k] > lmax / MAX_CONDITION {
            let v = vecs.col(k);
            inv += outer(v, v / vals[k]);
        } else {
            ill = true;
        }
    }
    (inv, ill)
}

/// Eigenvalues and eigenvectors (columns) of a symmetric 3×3 matrix by cyclic Jacobi.
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix formulas
pub fn sym_eigen(a: DMat3) -> ([f64; 3], DMat3) {
    let mut m = a.to_cols_array_2d(); // m[col][row]; symmetric so orientation is moot
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..50 {
        let off = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
        let diag = m[0][0] * m[0][0] + m[1][1] * m[1][1] + m[2][2] * m[2][2];
        if off <= 1e-30 * diag.max(1e-300) {
            break;
        }
        for (p, q) in [(0usize, 1usize), (0, 2), (1, 2)] {
            if m[p][q].abs() < 1e-300 {
                continue;
            }
            let theta = (m[q][q] - m[p][p]) / (2.0 * m[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // m ← Gᵀ m G with the rotation G in the (p, q) plane.
            for k in 0..3 {
                let mkp = m[k][p];
                let mkq = m[k][q];
                m[k][p] = c * mkp - s * mkq;
                m[k][q] = s * mkp + c * mkq;
            }
            for k in 0..3 {
                let mpk = m[p][k];
                let mqk = m[q][k];
                m[p][k] = c * mpk - s * mqk;
                m[q][k] = s * mpk + c * mqk;
            }
            for row in &mut v {
                let vp = row[p];
                let vq = row[q];
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    // v[row][k]: component `row` of eigenvector k.
    let vecs = DMat3::from_cols(
        DVec3::new(v[0][0], v[1][0], v[2][0]),
        DVec3::new(v[0][1], v[1][1], v[2][1]),
        DVec3::new(v[0][2], v[1][2], v[2][2]),
    );
    ([m[0][0], m[1][1], m[2][2]], vecs)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Jacobi eigen-decomposition reconstructs a random symmetric matrix to 1e-12 relative.
    #[test]
    fn eigen_reconstructs() {
        let a = DMat3::from_cols_array(&[4.0, 1.0, 0.5, 1.0, 3.0, -0.2, 0.5, -0.2, 1.0]);
        let (vals, vecs) = sym_eigen(a);
        let r = vecs * DMat3::from_diagonal(DVec3::from(vals)) * vecs.transpose();
        let err = (r - a)
            .to_cols_array()
            .iter()
            .map(|v| v.abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-12 * 4.0, "reconstruction error {err}");
        let (inv, ill) = pseudo_inverse(a);
        assert!(!ill);
        let e = (inv * a - DMat3::IDENTITY)
            .to_cols_array()
            .iter()
            .map(|v| v.abs())
            .fold(0.0, f64::max);
        assert!(e < 1e-12, "inverse error {e}");
    }

    /// A rank-2 (coplanar) moment matrix is flagged and its null direction dropped.
    #[test]
    fn planar_is_ill_conditioned() {
        let a = DMat3::from_diagonal(DVec3::new(2.0, 3.0, 0.0));
        let (inv, ill) = pseudo_inverse(a);
        assert!(ill);
        assert!((inv.x_axis.x - 0.5).abs() < 1e-12 && inv.z_axis.z == 0.0);
    }
}
