//! Small dense linear algebra: symmetric eigen-decompositions by cyclic Jacobi, the
//! pseudo-inverse of a moment matrix, the cofactor matrix of a deformation gradient and
//! the rotational part of a deformation. Used by the MLS fit, the contact surface's
//! principal directions, the volume term, SPH's corotation and the implicit solve's
//! preconditioner.

use glam::{DMat3, DVec3, Mat3, Quat};

/// Condition number above which a moment matrix counts as ill-conditioned; its smallest
/// eigen-directions are then left out of the inverse (pseudo-inverse) instead of
/// amplifying noise (coplanar or collinear neighbourhoods, too few neighbours).
pub const MAX_CONDITION: f64 = 1.0e4;

/// Eigen-decomposition of a symmetric N×N matrix by cyclic Jacobi: eigenvalues and
/// eigenvectors (`vecs[row][k]` is component `row` of eigenvector k).
#[allow(clippy::needless_range_loop)] // index loops mirror the matrix formulas
pub fn jacobi_eigen<const N: usize>(mut m: [[f64; N]; N]) -> ([f64; N], [[f64; N]; N]) {
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

/// The monomials of degree 1 and 2 at `q`: `x, y, z, x², y², z², xy, yz, zx` (the
/// quadratic MLS fit's basis and, with a constant, the volume fit's).
#[inline]
pub fn quadratic_terms(q: DVec3) -> [f64; 9] {
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

/// The outer product `a bᵀ`.
#[inline]
pub fn outer(a: DVec3, b: DVec3) -> DMat3 {
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

/// Largest quaternion iterations per call of [`polar_rotation`] (warm-started,
/// usually one suffices).
const POLAR_ITERATIONS: usize = 4;

/// Rotation update (rad) below which the polar iteration stops. A rotation error δ
/// changes the strain `sym(Rᵀ F) − I` only at second order (δ²), so 1e-4 is ample and
/// f32 round-off (≈ 1e-7) never keeps the loop spinning.
const POLAR_TOLERANCE: f32 = 1e-4;

/// Rotation of `a` (Müller, Bender, Chentanez, Macklin 2016, "A robust method to
/// extract the rotational part of deformations"), warm-started from `q`.
#[inline]
pub fn polar_rotation(a: Mat3, mut q: Quat) -> Quat {
    if !(a.x_axis.length_squared() + a.y_axis.length_squared() + a.z_axis.length_squared())
        .is_finite()
    {
        return q;
    }
    for _ in 0..POLAR_ITERATIONS {
        let r = Mat3::from_quat(q);
        let num = r.x_axis.cross(a.x_axis) + r.y_axis.cross(a.y_axis) + r.z_axis.cross(a.z_axis);
        let den =
            (r.x_axis.dot(a.x_axis) + r.y_axis.dot(a.y_axis) + r.z_axis.dot(a.z_axis)).abs() + 1e-9;
        let omega = num / den;
        if omega.length_squared() < POLAR_TOLERANCE * POLAR_TOLERANCE {
            break;
        }
        // Rotation by ≈ |ω| about ω (exact direction, angle 2 atan(|ω|/2)): no sin/cos,
        // and the fixed point ω = 0 is the same.
        let half = omega * 0.5;
        q = (Quat::from_xyzw(half.x, half.y, half.z, 1.0) * q).normalize();
    }
    q
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
