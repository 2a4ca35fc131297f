//! Contact forces spread from the contact surfels to the phyxels (Keiser et al. 2004,
//! eqs. 8–9), with a couple that makes them act at the surfel.

use super::*;

/// Phyxels a contact force spreads over at least (paper §7.3: k = 6).
pub const MIN_DISTRIBUTION_PHYXELS: usize = 6;

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
/// phyxels once at the end. `crate::testing::distribute_reference` is the scalar
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
pub(crate) fn distribute_reference(
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
pub(super) fn distribute_one<const SCALAR_QUERY: bool>(
    c: &ContactSurfel,
    sign: f32,
    phyxels: &mut Phyxels,
    grid: &Grid,
    h: f32,
    near: &mut Vec<(usize, f32)>,
    knn: &mut Vec<(usize, f32)>,
) {
    let widened = spread_weights::<SCALAR_QUERY>(c.pos, grid, h, near, knn);
    let (total, m1, m2) = moments(near, phyxels, c.pos);
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

/// The weights' sum, first moments `Σ wᵢ yᵢ` and second moments `Σ wᵢ yᵢ yᵢᵀ` (xx, yy,
/// zz, xy, xz, yz) about `at` (`yᵢ = xᵢ − at`), for [`Couple`].
pub(crate) fn moments(
    near: &[(usize, f32)],
    phyxels: &Phyxels,
    at: Vec3,
) -> (f32, [f32; 3], [f32; 6]) {
    let mut total = 0.0f32;
    let mut m1 = [0.0f32; 3];
    let mut m2 = [0.0f32; 6];
    for e in near.iter() {
        total += e.1;
        let (w, y) = (e.1, phyxels.pos.get(e.0) - at);
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
    (total, m1, m2)
}

/// The phyxels that take the force of a contact surfel at `at` and their poly6 weights
/// (not normalised), in `near`: those within `h`, or the
/// [`MIN_DISTRIBUTION_PHYXELS`] nearest where fewer lie within it (then the support is
/// the farthest of them, and the result is `true`). The grid's order is deterministic.
pub(crate) fn spread_weights<const SCALAR_QUERY: bool>(
    at: Vec3,
    grid: &Grid,
    h: f32,
    near: &mut Vec<(usize, f32)>,
    knn: &mut Vec<(usize, f32)>,
) -> bool {
    near.clear();
    if SCALAR_QUERY {
        grid.for_each_within_scalar(at, h, |i, d2| near.push((i, d2)));
    } else {
        grid.for_each_within(at, h, |i, d2| near.push((i, d2)));
    }
    let mut support = h;
    let widened = near.len() < MIN_DISTRIBUTION_PHYXELS;
    if widened {
        grid.k_nearest(at, MIN_DISTRIBUTION_PHYXELS, knn);
        support = knn.last().map_or(h, |e| e.1.sqrt() * 1.001 + 1e-9);
        near.clear();
        near.extend_from_slice(knn);
    }
    for e in near.iter_mut() {
        e.1 = poly6_shape(e.1, support);
    }
    widened
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
pub(crate) struct Couple {
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
        let (centroid, d, inverse) = Self::inertia(at, total, m1, m2);
        let rhs = -d.cross(f.as_dvec3());
        let omega = if rhs.is_finite() {
            (inverse * rhs).as_vec3()
        } else {
            Vec3::ZERO
        };
        Self { centroid, omega }
    }

    /// The centroid `s_c + d` and the linear map `f ↦ ω = −I⁻¹ (d × f)` of
    /// [`Couple::at_surfel`] (zero where it is not finite).
    pub(crate) fn map(at: Vec3, total: f32, m1: [f32; 3], m2: [f32; 6]) -> (Vec3, DMat3) {
        let (centroid, d, inverse) = Self::inertia(at, total, m1, m2);
        // `−d × f = −[d]ₓ f`.
        let cross = -DMat3::from_cols(
            glam::DVec3::new(0.0, d.z, -d.y),
            glam::DVec3::new(-d.z, 0.0, d.x),
            glam::DVec3::new(d.y, -d.x, 0.0),
        );
        let map = inverse * cross;
        (centroid, if map.is_finite() { map } else { DMat3::ZERO })
    }

    /// The centroid `s_c + d`, `d`, and the (pseudo-)inverse of the weights' inertia
    /// tensor about the centroid (zero where it has no finite scale).
    fn inertia(at: Vec3, total: f32, m1: [f32; 3], m2: [f32; 6]) -> (Vec3, glam::DVec3, DMat3) {
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
        let scale = inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z;
        let centroid = (at.as_dvec3() + d).as_vec3();
        if scale.is_nan() || scale <= 0.0 {
            return (centroid, d, DMat3::ZERO);
        }
        let det = inertia.determinant();
        // `det ≥ 1e-3 tr³` bounds the smallest eigenvalue above 1e-3 of the largest
        // (`λ_min ≥ det / λ_max²`); a plane of phyxels gives 0.03, a ball 0.04.
        let inverse = if det > 1e-3 * scale.powi(3) {
            inertia.inverse()
        } else {
            // Nearly collinear phyxels (or weights dominated by one or two): a
            // pseudo-inverse over the directions they span.
            let (vals, vecs) = sym_eigen(inertia);
            let top = vals.iter().fold(0.0f64, |m, &v| m.max(v));
            (0..3)
                .filter(|&k| vals[k] > 1e-3 * top)
                .map(|k| {
                    let v = vecs.col(k);
                    DMat3::from_cols(v * v.x, v * v.y, v * v.z) * (1.0 / vals[k])
                })
                .fold(DMat3::ZERO, |a, m| a + m)
        };
        (centroid, d, inverse)
    }
}
