//! Broad phase (Keiser et al. 2004, §5): one axis-aligned box per object around its
//! surfels; pairs whose boxes overlap, with their intersection box B. Only surfels in B
//! are collision candidates.

use crate::columns::{LANES, Vec3s, load8};
use glam::Vec3;
use wide::f32x8;

/// Points per parallel task of [`Aabb::of`] (a multiple of the lane width): a 1M-surfel
/// object's box takes 0.3 ms on one core, a 10k one's a few microseconds.
pub const PARALLEL_CHUNK: usize = 1 << 16;

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (contains nothing, overlaps nothing).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box of points of which one has a non-finite coordinate: NaN corners, and
    /// it overlaps nothing, so that a blown-up object takes no part in contact (the
    /// world reports it instead: [`crate::world::NonFinite`]).
    pub const NON_FINITE: Aabb = Aabb {
        min: Vec3::NAN,
        max: Vec3::NAN,
    };

    /// Bounding box of the first `len` points of the columns (SIMD over lanes, and
    /// rayon over chunks of [`PARALLEL_CHUNK`] points for large sets: min and max give
    /// the same box in any order, up to the sign of a corner that is exactly zero, which
    /// no comparison sees); [`Aabb::NON_FINITE`] if a coordinate is infinite or NaN.
    pub fn of(points: &Vec3s) -> Aabb {
        use rayon::prelude::*;
        let n = points.len();
        let (x, y, z) = (&points.x[..n], &points.y[..n], &points.z[..n]);
        if n <= PARALLEL_CHUNK {
            return Self::of_columns(x, y, z);
        }
        let chunk = |k: usize| k * PARALLEL_CHUNK..((k + 1) * PARALLEL_CHUNK).min(n);
        (0..n.div_ceil(PARALLEL_CHUNK))
            .into_par_iter()
            .map(|k| Self::of_columns(&x[chunk(k)], &y[chunk(k)], &z[chunk(k)]))
            .reduce(|| Aabb::EMPTY, |a, b| a.union(&b))
    }

    /// [`Aabb::of`] of three equally long coordinate columns, on one thread (the
    /// advection takes each block's box with it while the block is still in cache).
    pub fn of_columns(x: &[f32], y: &[f32], z: &[f32]) -> Aabb {
        let n = x.len();
        if n == 0 {
            return Aabb::EMPTY;
        }
        let full = n / LANES * LANES;
        let mut lo = [f32x8::splat(f32::INFINITY); 3];
        let mut hi = [f32x8::splat(f32::NEG_INFINITY); 3];
        // `0·v` is 0 for a finite v and NaN for ±inf or NaN: summed, it flags a
        // non-finite point at the cost of two lane operations (the loop is memory-bound).
        let (mut flag, zero) = (f32x8::splat(0.0), f32x8::splat(0.0));
        let cols = [x, y, z];
        for at in (0..full).step_by(LANES) {
            for c in 0..3 {
                let v = load8(cols[c], at);
                lo[c] = lo[c].min(v);
                hi[c] = hi[c].max(v);
                flag += v * zero;
            }
        }
        let reduce =
            |v: f32x8, f: fn(f32, f32) -> f32, init: f32| v.to_array().into_iter().fold(init, f);
        let mut min = Vec3::new(
            reduce(lo[0], f32::min, f32::INFINITY),
            reduce(lo[1], f32::min, f32::INFINITY),
            reduce(lo[2], f32::min, f32::INFINITY),
        );
        let mut max = Vec3::new(
            reduce(hi[0], f32::max, f32::NEG_INFINITY),
            reduce(hi[1], f32::max, f32::NEG_INFINITY),
            reduce(hi[2], f32::max, f32::NEG_INFINITY),
        );
        let mut finite = flag.to_array().iter().all(|&f| f == 0.0);
        for i in full..n {
            let p = Vec3::new(x[i], y[i], z[i]);
            finite &= p.is_finite();
            min = min.min(p);
            max = max.max(p);
        }
        if !finite {
            return Aabb::NON_FINITE;
        }
        Aabb { min, max }
    }

    /// The union of `boxes` ([`Aabb::EMPTY`] for none, [`Aabb::NON_FINITE`] if one is):
    /// the box of a set from the boxes of its parts, exactly as [`Aabb::of`] of the
    /// whole (min and max do not round).
    pub fn of_boxes(boxes: &[Aabb]) -> Aabb {
        boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b))
    }

    /// Is this [`Aabb::NON_FINITE`] (a NaN corner)?
    pub fn is_non_finite(&self) -> bool {
        self.min.is_nan() || self.max.is_nan()
    }

    /// The intersection box, or `None` when the boxes do not overlap.
    pub fn intersection(&self, other: &Aabb) -> Option<Aabb> {
        let min = self.min.max(other.min);
        let max = self.max.min(other.max);
        (min.cmple(max).all()).then_some(Aabb { min, max })
    }

    /// The smallest box holding both (a non-finite box stays [`Aabb::NON_FINITE`]).
    pub fn union(&self, other: &Aabb) -> Aabb {
        if self.is_non_finite() || other.is_non_finite() {
            return Aabb::NON_FINITE;
        }
        Aabb {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// This box grown by `margin` on every side.
    pub fn widened(&self, margin: f32) -> Aabb {
        Aabb {
            min: self.min - Vec3::splat(margin),
            max: self.max + Vec3::splat(margin),
        }
    }

    /// Is `p` inside (boundary included)?
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
}

/// Two objects whose surfel boxes overlap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// Object indices, `a < b`.
    pub a: usize,
    pub b: usize,
    /// The intersection box B.
    pub bounds: Aabb,
}

/// All overlapping pairs in a fixed order (by `a`, then `b`); pairs of two static
/// objects are skipped (they never move, so they never need a response), and so are
/// [`Aabb::NON_FINITE`] boxes.
pub fn overlapping_pairs(boxes: &[Aabb], is_static: &[bool], out: &mut Vec<Pair>) {
    out.clear();
    for a in 0..boxes.len() {
        for b in a + 1..boxes.len() {
            if is_static[a] && is_static[b] {
                continue;
            }
            // (`Vec3::max` drops NaN, so a NaN box must be skipped, not intersected.)
            if boxes[a].is_non_finite() || boxes[b].is_non_finite() {
                continue;
            }
            if let Some(bounds) = boxes[a].intersection(&boxes[b]) {
                out.push(Pair { a, b, bounds });
            }
        }
    }
}

/// Points per block of [`points_in_blocks`] and of the advection, which takes each
/// block's box as it writes it (`SurfelBinding::block_boxes`) and, lazily, moves only
/// the blocks a step reads: at 1,024 the 1M `scale` step advects 220k surfels, at
/// 4,096 470k (blocks in Morton order reach further than their share of the surface).
pub const BLOCK: usize = 1024;
const _: () = assert!(BLOCK.is_multiple_of(LANES), "blocks are whole lane groups");

/// Indices of the points inside `bounds` (SIMD compare over lanes), appended to `out`.
pub fn points_in_box(points: &Vec3s, bounds: &Aabb, out: &mut Vec<u32>) {
    points_in_blocks(points, None, bounds, out);
}

/// [`points_in_box`], given (when `Some`) the boxes of the points' blocks of [`BLOCK`]
/// (block `b` holds points `b·BLOCK..`): blocks whose box misses `bounds` are skipped
/// unread. The same indices in the same order, as long as `blocks` bound the points (a
/// point with a non-finite coordinate is in no box, and its block's box is
/// [`Aabb::NON_FINITE`], which is scanned). `None` scans every point.
pub fn points_in_blocks(
    points: &Vec3s,
    blocks: Option<&[Aabb]>,
    bounds: &Aabb,
    out: &mut Vec<u32>,
) {
    let n = points.len();
    let Some(blocks) = blocks else {
        return scan_box(points, bounds, 0..n, out);
    };
    assert_eq!(
        blocks.len(),
        n.div_ceil(BLOCK),
        "points_in_blocks: one box per block of {BLOCK} points"
    );
    for (b, block) in blocks.iter().enumerate() {
        if block.is_non_finite() || block.intersection(bounds).is_some() {
            scan_box(points, bounds, b * BLOCK..((b + 1) * BLOCK).min(n), out);
        }
    }
}

/// The points of `range` (starting at a lane group) inside `bounds`, appended to `out`.
fn scan_box(points: &Vec3s, bounds: &Aabb, range: std::ops::Range<usize>, out: &mut Vec<u32>) {
    let lo = bounds.min.to_array().map(f32x8::splat);
    let hi = bounds.max.to_array().map(f32x8::splat);
    let cols = [&points.x, &points.y, &points.z];
    for at in range.clone().step_by(LANES) {
        let mut inside = f32x8::splat(f32::from_bits(u32::MAX));
        for c in 0..3 {
            let v = load8(cols[c], at);
            inside &= v.simd_ge(lo[c]) & v.simd_le(hi[c]);
        }
        let mut bits = inside.to_bitmask();
        while bits != 0 {
            let l = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            if at + l < range.end {
                out.push((at + l) as u32);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Aabb, BLOCK, PARALLEL_CHUNK, points_in_blocks, points_in_box};
    use crate::columns::Vec3s;
    use glam::Vec3;

    /// The box of a set larger than several parallel chunks (and not a whole number of
    /// lane groups) is the brute-force min and max, exactly; one NaN or infinite
    /// coordinate anywhere, the last chunk included, makes it `NON_FINITE`.
    #[test]
    fn parallel_box_is_the_exact_box() {
        let n = 3 * PARALLEL_CHUNK + 1237;
        let mut state = 12345u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let points: Vec<Vec3> = (0..n)
            .map(|i| Vec3::new(next(), next(), next()) * (1.0 + i as f32 * 1e-5))
            .collect();
        let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &p in &points {
            (min, max) = (min.min(p), max.max(p));
        }
        let mut cols = Vec3s::from_points(&points);
        let b = Aabb::of(&cols);
        assert_eq!((b.min, b.max), (min, max));
        for (at, bad) in [(n - 3, f32::NAN), (PARALLEL_CHUNK + 5, f32::INFINITY)] {
            let keep = cols.get(at);
            cols.set(at, Vec3::new(keep.x, bad, keep.z));
            assert!(Aabb::of(&cols).is_non_finite(), "{bad} at {at}");
            cols.set(at, keep);
        }
    }

    /// `points_in_blocks` against the full scan (`points_in_box`, itself against
    /// `Aabb::contains` point by point): for query boxes that cut a few blocks, hold
    /// none or hold all, over blocks boxed with `Aabb::of_columns` (the last one partial,
    /// one holding a NaN point, which no box contains), the same indices in the same
    /// order. A block whose box misses the query is not read: with one block's box
    /// replaced by an empty one, its points drop out.
    #[test]
    fn block_scan_is_the_full_scan() {
        let n = 5 * BLOCK + 1001;
        // Points along a helix, so that consecutive blocks lie in different places.
        let mut points: Vec<Vec3> = (0..n)
            .map(|i| {
                let t = i as f32 * 1e-3;
                Vec3::new(t.cos(), t.sin(), 0.1 * t)
            })
            .collect();
        points[2 * BLOCK + 17] = Vec3::new(f32::NAN, 0.0, 0.0);
        let cols = Vec3s::from_points(&points);
        let blocks: Vec<Aabb> = (0..n.div_ceil(BLOCK))
            .map(|b| {
                let r = b * BLOCK..((b + 1) * BLOCK).min(n);
                Aabb::of_columns(&cols.x[r.clone()], &cols.y[r.clone()], &cols.z[r])
            })
            .collect();
        assert!(blocks[2].is_non_finite());
        let queries = [
            Aabb {
                min: Vec3::new(-0.5, 0.2, 0.3),
                max: Vec3::new(0.9, 1.0, 1.2),
            },
            Aabb {
                min: Vec3::splat(-2.0),
                max: Vec3::splat(3.0),
            },
            Aabb {
                min: Vec3::splat(5.0),
                max: Vec3::splat(6.0),
            },
            Aabb {
                min: Vec3::new(-1.0, -1.0, 1.5),
                max: Vec3::new(1.0, 1.0, 1.6),
            },
        ];
        for q in &queries {
            let (mut full, mut blocked) = (Vec::new(), Vec::new());
            points_in_box(&cols, q, &mut full);
            points_in_blocks(&cols, Some(&blocks), q, &mut blocked);
            let brute: Vec<u32> = (0..n as u32)
                .filter(|&i| q.contains(points[i as usize]))
                .collect();
            assert_eq!(full, brute, "{q:?}");
            assert_eq!(blocked, full, "{q:?}");
        }
        let q = &queries[1];
        let mut skipped = blocks.clone();
        skipped[1] = Aabb::EMPTY;
        let mut got = Vec::new();
        points_in_blocks(&cols, Some(&skipped), q, &mut got);
        assert!(
            got.iter()
                .all(|&i| !(BLOCK..2 * BLOCK).contains(&(i as usize)))
        );
        assert_eq!(got.len(), n - 1 - BLOCK);
    }
}
