//! Storage order of sampled points: Morton (Z-order) of coarse cells.
//!
//! A shape's sampler emits surfels in its own order (the sphere's golden-angle spiral
//! puts consecutive surfels far apart), and every per-surfel pass then reads its
//! neighbours' data from all over memory: the advection's phyxel rows, the grid build's
//! slots, the contact surface's patches. Stored in Morton order of cells a few surfels
//! wide, neighbouring surfels sit next to each other in the columns, so those reads hit
//! the cache (docs/PERFORMANCE.md, "Rules"). Only the storage order
//! changes: the surfels and the physics are the same, up to the order of floating-point
//! sums.

use glam::Vec3;

/// Bits per axis of a cell coordinate in the key (3 × 21 = 63 bits).
const AXIS_BITS: u32 = 21;

/// Spreads the low [`AXIS_BITS`] bits of `v` to every third bit of the result.
fn spread3(v: u32) -> u64 {
    let mut x = u64::from(v) & ((1 << AXIS_BITS) - 1);
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The Morton key of cell `c` (coordinates below 2²¹).
pub fn key([x, y, z]: [u32; 3]) -> u64 {
    spread3(x) | spread3(y) << 1 | spread3(z) << 2
}

/// The permutation that stores `points` in Morton order of cubic cells of edge `cell`
/// (> 0) anchored at the points' lower corner: `order[k]` is the point stored k-th.
/// Points of one cell keep their relative order; a cell coordinate beyond 2²¹ − 1 (a
/// cloud more than two million cells wide) is clamped, and a non-finite coordinate
/// counts as 0, which only costs locality.
pub fn order(points: &[Vec3], cell: f32) -> Vec<usize> {
    let finite = |v: f32| if v.is_finite() { v } else { 0.0 };
    let lo = points
        .iter()
        .map(|p| Vec3::new(finite(p.x), finite(p.y), finite(p.z)))
        .fold(Vec3::splat(f32::INFINITY), Vec3::min);
    let top = ((1u32 << AXIS_BITS) - 1) as f32;
    // `as u32` saturates and maps NaN to 0.
    let coord = |v: f32, lo: f32| ((v - lo) / cell).clamp(0.0, top) as u32;
    let mut keyed: Vec<(u64, usize)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            (
                key([coord(p.x, lo.x), coord(p.y, lo.y), coord(p.z, lo.z)]),
                i,
            )
        })
        .collect();
    // The index breaks ties, so the order is unique and the unstable sort deterministic.
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The key interleaves the bits: x in bit 0, y in bit 1, z in bit 2, and so on up
    /// to bit 62 (checked against a bit-by-bit construction).
    #[test]
    fn key_interleaves_bits() {
        let slow = |[x, y, z]: [u32; 3]| {
            (0..AXIS_BITS).fold(0u64, |k, b| {
                k | (u64::from(x >> b & 1) << (3 * b))
                    | (u64::from(y >> b & 1) << (3 * b + 1))
                    | (u64::from(z >> b & 1) << (3 * b + 2))
            })
        };
        let mut s = 0x9E37_79B9u32;
        for _ in 0..1000 {
            let mut next = || {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                s & ((1 << AXIS_BITS) - 1)
            };
            let c = [next(), next(), next()];
            assert_eq!(key(c), slow(c), "cell {c:?}");
        }
        assert_eq!(key([(1 << AXIS_BITS) - 1; 3]), (1 << 63) - 1);
    }

    /// A permutation, cells contiguous and in key order, ties in input order; a NaN
    /// point is kept. The cloud's lower corner is (−1, −1, −1).
    #[test]
    fn order_is_a_cell_sorted_permutation() {
        let pts: Vec<Vec3> = (0..500)
            .map(|i| {
                let t = i as f32 * 2.399_963;
                Vec3::new(t.cos(), (i as f32 / 250.0) - 1.0, t.sin())
            })
            .chain([Vec3::splat(-1.0), Vec3::NAN])
            .collect();
        let cell = 0.3;
        let o = order(&pts, cell);
        let mut seen = o.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..pts.len()).collect::<Vec<_>>());
        let k = |i: usize| {
            let p = pts[i];
            let c = |v: f32| {
                if v.is_nan() {
                    0
                } else {
                    ((v + 1.0) / cell) as u32
                }
            };
            key([c(p.x), c(p.y), c(p.z)])
        };
        for w in o.windows(2) {
            assert!(
                (k(w[0]), w[0]) < (k(w[1]), w[1]),
                "{} before {}",
                w[0],
                w[1]
            );
        }
    }
}
