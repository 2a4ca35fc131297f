//! Phyxel volumes as a quadrature that integrates the shape's moments exactly.
//!
//! Nodal integration sums each phyxel's energy density times its volume. With every
//! lattice cell's volume the sum is the midpoint rule, which counts `1 − 1/n²` of a
//! section's second moment at `n` phyxels through it (a bar's bending stiffness 4% low at
//! 5 through) and, on a curved or meshed boundary, misses the volume between the lattice
//! and the surface. Moment fitting fixes both for every shape: the volumes `Vᵢ` closest
//! to the cell volume `V₀` (least squares relative to it) with
//! `Σ Vᵢ p(xᵢ) = ∫_Ω p dV` for every polynomial `p` of degree ≤ 2, so that the mass, the
//! centre of mass, the inertia tensor and the bending energy of a linearly varying
//! strain are the solid's. The solution is `Vᵢ = V₀ (1 + λ·p(xᵢ))`, a smooth quadratic
//! correction, with `λ` from a 10×10 system.

use glam::{DMat3, DVec3, Vec3};

use super::Shape;
use crate::body::mesh::Surface;
use crate::math::linalg;

/// Volume moments of a solid in object coordinates: `∫ 1`, `∫ x` and `∫ x xᵀ` (m³, m⁴, m⁵).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moments {
    pub volume: f64,
    pub first: DVec3,
    pub second: DMat3,
}

/// How far a fitted volume may stray from the cell volume, as a factor either way:
/// beyond it the shape is too thin or ragged for the lattice to carry its moments, and
/// the lattice's volumes are kept, scaled to the solid's volume. (A bar 3 phyxels
/// through needs half the cell volume on its centre line; the stable step follows the
/// masses, so light phyxels cost time, not stability.)
const LARGEST_FACTOR: f64 = 4.0;

/// A correction below this share of the cell volume is the rounding of positions that
/// already integrate the moments (a box's spread layers): the cell volume is kept.
const ROUNDING: f64 = 1e-5;

/// An eigenvalue of the conditions' Gram matrix below this share of the largest marks a
/// moment the points cannot carry independently of the others (all phyxels in one layer
/// have no second moment across it); that condition is dropped.
const DEPENDENT: f64 = 1e-9;

impl Moments {
    /// A solid centred on the origin with the given volume and second moment.
    fn centred(volume: f64, central: DMat3) -> Self {
        Moments {
            volume,
            first: DVec3::ZERO,
            second: central,
        }
    }
}

impl Shape {
    /// The solid's exact volume moments in object coordinates, or `None` where they are
    /// known only approximately (a point cloud's estimated areas) or the shape has no
    /// volume (a plane).
    pub fn moments(&self) -> Option<Moments> {
        let diag = |v: f64, x2: f64, y2: f64, z2: f64| {
            Moments::centred(v, DMat3::from_diagonal(DVec3::new(x2, y2, z2) * v))
        };
        match *self {
            Shape::Sphere { radius } => {
                let r = radius as f64;
                let v = 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
                Some(diag(v, r * r / 5.0, r * r / 5.0, r * r / 5.0))
            }
            Shape::Box { size } => {
                let [x, y, z] = size.map(|s| s as f64);
                Some(diag(x * y * z, x * x / 12.0, y * y / 12.0, z * z / 12.0))
            }
            Shape::Capsule { radius, length } => {
                // A cylinder along y and two hemispheres centred at y = ±length/2.
                let (r, l) = (radius as f64, length as f64);
                let pi = std::f64::consts::PI;
                let cyl = pi * r * r * l;
                let ball = 4.0 / 3.0 * pi * r.powi(3);
                let across = cyl * r * r / 4.0 + ball * r * r / 5.0;
                // Each cap: ∫(l/2 + y')² over the hemisphere y' ≥ 0, where ∫y' = πr⁴/4
                // and ∫y'² = 2πr⁵/15.
                let along = cyl * l * l / 12.0
                    + ball * l * l / 4.0
                    + pi * l * r.powi(4) / 2.0
                    + 4.0 * pi * r.powi(5) / 15.0;
                let m = DMat3::from_diagonal(DVec3::new(across, along, across));
                Some(Moments::centred(cyl + ball, m))
            }
            Shape::Torus { major, minor } => {
                let (big, r) = (major as f64, minor as f64);
                let v = 2.0 * std::f64::consts::PI.powi(2) * big * r * r;
                let around = big * big / 2.0 + 3.0 * r * r / 8.0;
                Some(diag(v, around, r * r / 4.0, around))
            }
            Shape::Plane { .. } => None,
            Shape::Mesh { ref mesh, .. } => match mesh.as_deref() {
                Some(Surface::Triangles(m)) => Some(mesh_moments(
                    m.triangles
                        .iter()
                        .map(|t| t.map(|i| m.vertices[i as usize].as_dvec3())),
                )),
                _ => None,
            },
        }
    }
}

/// Moments of a closed, consistently oriented triangle mesh: a sum over the signed
/// tetrahedra from the origin to each triangle (`∫_T x xᵀ = V/20 (Σ vᵢvᵢᵀ + s sᵀ)`,
/// `s = Σ vᵢ` over the four corners, the origin one of them), in f64.
pub fn mesh_moments(triangles: impl Iterator<Item = [DVec3; 3]>) -> Moments {
    let mut volume = 0.0;
    let mut first = DVec3::ZERO;
    let mut second = DMat3::ZERO;
    for [a, b, c] in triangles {
        let v = a.dot(b.cross(c)) / 6.0;
        let s = a + b + c;
        volume += v;
        first += v / 4.0 * s;
        let outer = |p: DVec3| linalg::outer(p, p);
        second += (outer(a) + outer(b) + outer(c) + outer(s)) * (v / 20.0);
    }
    if volume < 0.0 {
        // Oriented inward: the same solid.
        return Moments {
            volume: -volume,
            first: -first,
            second: -second,
        };
    }
    Moments {
        volume,
        first,
        second,
    }
}

/// The ten monomials of degree ≤ 2 at `x` (scaled to order one by the caller).
fn monomials(x: DVec3) -> [f64; 10] {
    let q = linalg::quadratic_terms(x);
    [1.0, q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8]]
}

/// The same monomials integrated over the solid, in coordinates divided by `scale`
/// per axis.
fn integrals(m: &Moments, scale: DVec3) -> [f64; 10] {
    let (v, f) = (m.volume, m.first / scale);
    let s = DMat3::from_diagonal(scale.recip());
    let s = s * m.second * s;
    [
        v, f.x, f.y, f.z, s.x_axis.x, s.y_axis.y, s.z_axis.z, s.y_axis.x, s.z_axis.y, s.x_axis.z,
    ]
}

/// Phyxel volumes at `points` (object coordinates) that integrate `moments` exactly
/// (module doc), starting from each point's cell volume `cells[i]` (one lattice cell,
/// or a graded lattice's leaf: [`super::graded`]) and each within a factor
/// `LARGEST_FACTOR` (4) of it. Where no such volumes exist: the cell volumes scaled so
/// that they sum to the solid's, or the cell volumes themselves when even that is
/// further off (a shape much thinner than the spacing).
///
/// # Panics
/// If `cells` does not hold one volume per point.
pub fn fitted_volumes(points: &[Vec3], cells: &[f32], moments: &Moments) -> Vec<f32> {
    assert_eq!(points.len(), cells.len(), "one cell volume per point");
    let largest_cell = cells.iter().fold(0.0f32, |m, &c| m.max(c));
    // Per axis, so that a thin direction's conditions weigh as much as a long one's.
    let scale = points
        .iter()
        .fold(DVec3::ZERO, |m, p| m.max(p.abs().as_dvec3()))
        .max(DVec3::splat(largest_cell.cbrt() as f64));
    let basis: Vec<[f64; 10]> = points
        .iter()
        .map(|p| monomials(p.as_dvec3() / scale))
        .collect();
    let mut gram = [[0.0f64; 10]; 10];
    let mut rhs = integrals(moments, scale);
    for (p, &v0) in basis.iter().zip(cells) {
        let v0 = v0 as f64;
        for a in 0..10 {
            rhs[a] -= v0 * p[a];
            for b in 0..10 {
                gram[a][b] += v0 * p[a] * p[b];
            }
        }
    }
    let lambda = pseudo_solve(gram, rhs);
    // The correction factor `λ·p(xᵢ)` per point.
    let factor: Vec<f64> = basis
        .iter()
        .map(|p| (0..10).map(|a| lambda[a] * p[a]).sum::<f64>())
        .collect();
    if factor.iter().all(|&f| f.abs() < ROUNDING) {
        return cells.to_vec();
    }
    let within = |f: f64| (1.0 / LARGEST_FACTOR..=LARGEST_FACTOR).contains(&f);
    if factor.iter().all(|&f| within(1.0 + f)) {
        return cells
            .iter()
            .zip(&factor)
            .map(|(&v0, f)| (v0 as f64 * (1.0 + f)) as f32)
            .collect();
    }
    let total: f64 = cells.iter().map(|&c| c as f64).sum();
    let scaled = moments.volume / total;
    let s = if within(scaled) { scaled } else { 1.0 };
    cells.iter().map(|&c| (c as f64 * s) as f32).collect()
}

/// Solves the symmetric positive semi-definite `a x = b` in the eigen-directions of `a`
/// above [`DEPENDENT`] of its largest eigenvalue: a condition the points cannot carry
/// apart from the others (no second moment across one layer) is dropped.
fn pseudo_solve(a: [[f64; 10]; 10], b: [f64; 10]) -> [f64; 10] {
    let (vals, vecs) = linalg::jacobi_eigen(a);
    let largest = vals.iter().fold(0.0f64, |m, &v| m.max(v));
    let mut x = [0.0; 10];
    for k in 0..10 {
        if vals[k].is_nan() || vals[k] <= DEPENDENT * largest {
            continue;
        }
        let along = (0..10).map(|r| vecs[r][k] * b[r]).sum::<f64>() / vals[k];
        for (r, xr) in x.iter_mut().enumerate() {
            *xr += along * vecs[r][k];
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shape tests' primitives with a volume (all but the plane).
    fn solids() -> Vec<Shape> {
        let all = crate::body::shape::tests::shapes();
        all.into_iter().filter(|s| s.moments().is_some()).collect()
    }

    fn close(a: &Moments, b: &Moments, tol: f64) -> bool {
        let l2 = a.volume.powf(2.0 / 3.0);
        (a.volume - b.volume).abs() < tol * a.volume
            && (a.first - b.first).length() < tol * a.volume * l2.sqrt()
            && (a.second - b.second)
                .to_cols_array()
                .iter()
                .all(|d| d.abs() < tol * a.volume * l2)
    }

    /// The analytic moments against an independent sum: the tetrahedra of each
    /// primitive's triangulation (`triangulate`, 2 mm edges), whose inscribed polyhedron
    /// approaches the solid as the square of the edge (0.1% here).
    #[test]
    fn analytic_moments_match_the_triangulated_solid() {
        for shape in solids() {
            let exact = shape.moments().unwrap();
            let (v, t) = shape.triangulate(0.002).unwrap();
            let mesh = mesh_moments(t.iter().map(|t| t.map(|i| v[i as usize].as_dvec3())));
            assert!(
                close(&exact, &mesh, 1e-3),
                "{shape:?}: {exact:?} against {mesh:?}"
            );
        }
    }

    /// The fitted volumes integrate every monomial of degree ≤ 2 as the solid does
    /// (relative 1e-6, f32 volumes) and stay within the stated share of the cell volume,
    /// at a coarse and a finer spacing; the mass (the zeroth moment) is the solid's.
    #[test]
    fn fitted_volumes_integrate_quadratics_exactly() {
        for shape in solids() {
            let exact = shape.moments().unwrap();
            for per in [6.0, 12.0] {
                let spacing = shape.half_extents().min_element() * 2.0 / per;
                let s = shape.sample_volume(spacing);
                let v = fitted_volumes(&s.positions, &s.volumes, &exact);
                let scale = shape.half_extents().as_dvec3();
                let want = integrals(&exact, scale);
                let mut got = [0.0; 10];
                for (p, &w) in s.positions.iter().zip(&v) {
                    let m = monomials(p.as_dvec3() / scale);
                    for a in 0..10 {
                        got[a] += w as f64 * m[a];
                    }
                }
                for a in 0..10 {
                    assert!(
                        (got[a] - want[a]).abs() < 1e-5 * exact.volume,
                        "{shape:?} at {per} across, monomial {a}: {} against {}",
                        got[a],
                        want[a]
                    );
                }
                let v0 = s.cell_volume as f64;
                assert!(
                    v.iter().all(
                        |&w| w as f64 >= v0 / LARGEST_FACTOR && w as f64 <= v0 * LARGEST_FACTOR
                    )
                );
            }
        }
    }

    /// A plate one phyxel thick cannot carry a second moment across itself: that
    /// condition is dropped and the rest still hold; a plate far thinner than a cell
    /// keeps the cell volume (a correction past the stated share).
    #[test]
    fn thin_plates_drop_what_they_cannot_carry() {
        let plate = Shape::Box {
            size: [0.4, 0.008, 0.3],
        };
        let s = plate.sample_volume(0.01);
        let y0 = s.positions[0].y;
        assert!(s.positions.iter().all(|p| p.y == y0), "one layer");
        let exact = plate.moments().unwrap();
        let v = fitted_volumes(&s.positions, &s.volumes, &exact);
        let total: f64 = v.iter().map(|&w| w as f64).sum();
        assert!(
            (total / exact.volume - 1.0).abs() < 1e-5,
            "{total} against {}",
            exact.volume
        );
        let sheet = Shape::Box {
            size: [0.4, 0.002, 0.3],
        };
        let s = sheet.sample_volume(0.01);
        let v = fitted_volumes(&s.positions, &s.volumes, &sheet.moments().unwrap());
        assert!(v.iter().all(|&w| w == s.cell_volume));
    }
}
