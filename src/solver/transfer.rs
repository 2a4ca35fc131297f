//! The springs' reading of an island's phyxel velocities and its transpose, the
//! spreading of their forces ([`ContactSprings::velocity`], [`ContactSprings::spread`]),
//! in eight-float lanes: the products CG repeats each iteration.
//!
//! A side reads `Σ ŵⱼ vⱼ + Cᵀ Σ ŵⱼ rⱼ × vⱼ` with `rⱼ = xⱼ − c` (`c` the weights'
//! centroid). Written as `Σ ŵⱼ xⱼ × vⱼ − c × Σ ŵⱼ vⱼ`, every side reads the same six
//! numbers per phyxel, `[vⱼ, xⱼ × vⱼ]`, formed once per product: a weight costs one lane
//! load and one fused multiply-add. Spreading is its transpose: a side adds
//! `ŵⱼ [f − ω × c, ω]` to its phyxels' sums, and each phyxel then takes
//! `F + Ω × xⱼ`. Positions are taken from each member's mean position, so that the
//! cross products stay of the size of the body rather than of its place in the world.

use super::active::Side;
use super::springs::{ContactSprings, SpringSide};
use crate::points::phyxels::Phyxels;
use glam::{DVec3, Vec3};
use wide::f32x8;

/// The island's positions and lanes, kept between steps (no allocation in the steady
/// step).
#[derive(Clone, Debug, Default)]
pub struct Transfer {
    /// Each island row's phyxel position from its member's mean position (m).
    local: Vec<Vec3>,
    /// Per row, `[v, local × v, 0, 0]` of the vector last [`Transfer::load`]ed.
    lanes: Vec<f32x8>,
}

impl Transfer {
    /// Takes the positions of an island's members, in the order of its rows, for a
    /// solve.
    pub fn begin<'a>(&mut self, members: impl IntoIterator<Item = &'a Phyxels>) {
        self.local.clear();
        for phyxels in members {
            let (pos, n) = (&phyxels.pos, phyxels.len());
            let sum = (0..n).fold(DVec3::ZERO, |s, j| s + pos.get(j).as_dvec3());
            let origin = (sum / n.max(1) as f64).as_vec3();
            self.local.extend((0..n).map(|j| pos.get(j) - origin));
        }
        self.lanes.clear();
        self.lanes.resize(self.local.len(), f32x8::ZERO);
    }

    /// The weighted centroid of a spring side whose member's rows start at `offset`,
    /// from the member's mean position (m).
    pub fn centroid(&self, springs: &ContactSprings, side: &SpringSide, offset: usize) -> Vec3 {
        let (mut sum, mut total) = (Vec3::ZERO, 0.0f32);
        for &(j, w) in springs.weights_of(side) {
            sum += self.local[offset + j as usize] * w;
            total += w;
        }
        sum / total
    }

    /// A member's rows of positions (m), from its first row `at`, `n` rows.
    pub fn local(&self, at: usize, n: usize) -> &[Vec3] {
        &self.local[at..at + n]
    }

    /// The offset of row `i`'s phyxel from a side's `centroid` (m).
    pub fn offset(&self, i: usize, centroid: Vec3) -> Vec3 {
        self.local[i] - centroid
    }

    /// Forms the lanes of the island vector `x` (one entry per row).
    pub fn load(&mut self, x: &[Vec3]) {
        for ((lane, &l), &v) in self.lanes.iter_mut().zip(&self.local).zip(x) {
            let m = l.cross(v);
            *lane = f32x8::from([v.x, v.y, v.z, m.x, m.y, m.z, 0.0, 0.0]);
        }
    }

    /// A side's contact surfel velocity from the vector last loaded.
    pub fn read(&self, springs: &ContactSprings, side: &Side) -> Vec3 {
        let lanes = &self.lanes[side.offset..];
        let term =
            |&(j, w): &(u32, f32), acc: f32x8| lanes[j as usize].mul_add(f32x8::splat(w), acc);
        // Four sums: each fused multiply-add waits on its own sum's last one only.
        let weights = springs.weights_of(&side.spring);
        let mut acc = [f32x8::ZERO; 4];
        let mut quads = weights.chunks_exact(4);
        for q in &mut quads {
            for (a, w) in acc.iter_mut().zip(q) {
                *a = term(w, *a);
            }
        }
        for (a, w) in acc.iter_mut().zip(quads.remainder()) {
            *a = term(w, *a);
        }
        let a = ((acc[0] + acc[1]) + (acc[2] + acc[3])).to_array();
        let mean = Vec3::new(a[0], a[1], a[2]);
        let moment = Vec3::new(a[3], a[4], a[5]) - side.centroid.cross(mean);
        mean + side.spring.couple.transpose() * moment
    }
}

/// Adds a side's share of `f` to `sums`, its member's rows of per-phyxel sums (see the
/// module; [`finish`] turns them into forces).
pub fn spread(sums: &mut [f32x8], springs: &ContactSprings, side: &Side, f: Vec3) {
    let omega = side.spring.couple * f;
    let base = f - omega.cross(side.centroid);
    let share = f32x8::from([base.x, base.y, base.z, omega.x, omega.y, omega.z, 0.0, 0.0]);
    for &(j, w) in springs.weights_of(&side.spring) {
        let sum = &mut sums[j as usize];
        *sum = share.mul_add(f32x8::splat(w), *sum);
    }
}

/// Adds each phyxel's spread forces, `F + Ω × x`, to `rows` (a member's rows, `local`
/// its positions), but to its fixed phyxels (`fixed[j] != 0`).
pub fn finish(sums: &[f32x8], local: &[Vec3], fixed: &[u8], rows: &mut [Vec3]) {
    for (((sum, &l), &fixed), row) in sums.iter().zip(local).zip(fixed).zip(rows) {
        if fixed == 0 {
            let a = sum.to_array();
            *row += Vec3::new(a[0], a[1], a[2]) + Vec3::new(a[3], a[4], a[5]).cross(l);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat3;

    /// Two bodies 10 m from the origin (the positions' magnitude a thousand times the
    /// offsets'), a side on the second with a couple: the lanes' reading equals
    /// [`ContactSprings::velocity`] and their spreading [`ContactSprings::spread`],
    /// to 1e-5 of the values' size (f32 rounding), and spreading is reading's transpose
    /// (`f · read(x) = x · spread(f)`).
    #[test]
    fn lanes_read_and_spread_as_the_springs_do() {
        let lattice = |shift: Vec3| -> Vec<Vec3> {
            (0..27)
                .map(|i| {
                    shift + 0.01 * Vec3::new((i % 3) as f32, (i / 3 % 3) as f32, (i / 9) as f32)
                })
                .collect()
        };
        let first = Phyxels::at_rest(&lattice(Vec3::new(10.0, 0.0, 0.0)), 1e-6, 1000.0);
        let second = Phyxels::at_rest(&lattice(Vec3::new(10.0, 0.1, 0.0)), 1e-6, 1000.0);
        let weights: Vec<(u32, f32)> = (0..27)
            .filter(|j| j % 4 != 1)
            .map(|j| (j as u32, 1.0 + (j % 5) as f32))
            .collect();
        let total: f32 = weights.iter().map(|w| w.1).sum();
        let springs = ContactSprings {
            springs: Vec::new(),
            weights: weights.iter().map(|&(j, w)| (j, w / total)).collect(),
        };
        let spring = SpringSide {
            object: 1,
            start: 0,
            end: weights.len() as u32,
            couple: Mat3::from_cols_array(&[30.0, -4.0, 2.0, 5.0, -20.0, 1.0, 3.0, 7.0, 12.0]),
        };
        let mut transfer = Transfer::default();
        transfer.begin([&first, &second]);
        let side = Side {
            offset: 27,
            member: 1,
            spring,
            centroid: transfer.centroid(&springs, &spring, 27),
        };
        let x: Vec<Vec3> = (0..54)
            .map(|i| {
                Vec3::new(
                    (i as f32 * 0.7).sin(),
                    (i as f32 * 1.3).cos(),
                    0.1 * i as f32 - 2.0,
                )
            })
            .collect();
        transfer.load(&x);
        let pos = |j: usize| second.pos.get(j);
        let reference = springs.velocity(&spring, pos, |j| x[27 + j]);
        let read = transfer.read(&springs, &side);
        assert!(
            (read - reference).length() <= 1e-5 * reference.length(),
            "{read} {reference}"
        );

        let f = Vec3::new(0.3, -1.1, 0.6);
        let mut sums = vec![f32x8::ZERO; 27];
        spread(&mut sums, &springs, &side, f);
        let mut rows = vec![Vec3::ZERO; 27];
        finish(&sums, transfer.local(27, 27), &[0; 27], &mut rows);
        let mut expected = vec![Vec3::ZERO; 27];
        springs.spread(&spring, f, pos, |j, fj| expected[j] += fj);
        let size = expected.iter().map(|e| e.length()).fold(0.0, f32::max);
        for (r, e) in rows.iter().zip(&expected) {
            assert!((*r - *e).length() <= 1e-5 * size, "{r} {e}");
        }
        let work: f32 = rows.iter().zip(&x[27..]).map(|(r, x)| r.dot(*x)).sum();
        assert!((work - f.dot(read)).abs() <= 1e-5 * f.length() * reference.length());
    }
}
