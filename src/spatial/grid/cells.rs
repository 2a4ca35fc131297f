//! Cells and buckets of the grid: the dense or hashed table layout (Teschner et al.
//! 2003), cell coordinates of points and lanes, bucket counts and prefix sums, packed
//! records for the scatter, and the row separation of query boxes.

use super::*;

/// Largest query box, in rows per axis, covered by [`row_separation`].
pub(super) const SEP: usize = 8;

/// Hash multipliers of the y and z cell indices (Teschner et al.'s primes), for point
/// sets whose bounding box holds too many cells for a dense table (see [`Layout`]).
pub(super) const P2: u32 = 19_349_663;
pub(super) const P3: u32 = 83_492_791;

/// A dense table may have up to this many times the buckets of the hashed one (which
/// has at least twice the point count): the 1M `scale` scene's contact-region grid (83k
/// surfels, 350k cells in its box) runs 1–13% faster dense than hashed, and a factor of 4
/// gains nothing more (measured on that scene with `phyxel run scale`).
pub(super) const DENSE_TABLE_FACTOR: u64 = 2;

/// How cells map to buckets: `h(x, y, z) = x + p2·y + p3·z mod (mask + 1)`.
///
/// When the points' bounding box holds no more cells than [`DENSE_TABLE_FACTOR`] times
/// a table of about twice the point count, the grid is *dense*: `p2`, `p3` are the
/// box's row and layer lengths in cells, so every cell of the box has its own bucket,
/// in row-major order (no two cells collide, and cells near in y and z are near in the
/// table and in the sorted arrays, which the build's counts and scatter and every
/// query's reads find in cache). Otherwise (a large thin shell, say) the multipliers
/// are [`P2`], [`P3`] in a table of at least twice the point count. Either way the hash
/// is additive in x and linear, which the queries rely on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Layout {
    /// Table size minus one (the table size is a power of two).
    pub(super) mask: usize,
    pub(super) p2: u32,
    pub(super) p3: u32,
}

impl Layout {
    /// Buckets of the hashed table for `n` points: at least twice the point count.
    pub(super) fn hashed_table(n: usize) -> usize {
        (2 * n).next_power_of_two().max(16)
    }

    /// The layout for `n` points whose cells span `lo..=hi` (`None`: no indexable point).
    pub(super) fn new(n: usize, bounds: Option<[[i32; 3]; 2]>) -> Self {
        let hashed = Self::hashed_table(n);
        let prime = Self {
            mask: hashed - 1,
            p2: P2,
            p3: P3,
        };
        let Some([lo, hi]) = bounds else {
            return prime;
        };
        let e: [u64; 3] = std::array::from_fn(|a| (hi[a] as i64 - lo[a] as i64 + 1) as u64);
        let cells = e[0].saturating_mul(e[1]).saturating_mul(e[2]);
        if cells > DENSE_TABLE_FACTOR * hashed as u64 {
            return prime;
        }
        let table = (cells as usize).next_power_of_two().max(16);
        Self {
            mask: table - 1,
            p2: e[0] as u32,
            p3: (e[0] * e[1]) as u32,
        }
    }
}

/// Bucket marker of a point left out of the grid (a NaN coordinate).
pub(super) const SKIPPED: u32 = u32::MAX;

/// `floor(v)` as an `i32`, saturating at the `i32` range, 0 for NaN. Monotone in `v`.
///
/// Written out because without SSE4.1 (the default x86-64 target) `f32::floor` is a
/// libm call; the grid uses this one function for building and querying alike, so
/// cell assignment is consistent by construction.
#[inline(always)]
pub(super) fn floor_i32(v: f32) -> i32 {
    let t = v as i32; // truncates toward zero, saturates, NaN → 0
    if (t as f32) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

#[inline(always)]
pub(super) fn cell_of(p: Vec3, inv_cell: f32) -> [i32; 3] {
    [
        floor_i32(p.x * inv_cell),
        floor_i32(p.y * inv_cell),
        floor_i32(p.z * inv_cell),
    ]
}

/// [`floor_i32`] of eight values: the same saturation (`trunc_int` saturates like `as`,
/// NaN → 0) and the same step down where truncation rounded up.
#[inline(always)]
pub(super) fn floor_lanes(v: f32x8) -> i32x8 {
    let t = v.trunc_int();
    let above: i32x8 = wide::bytemuck::cast(t.round_float().simd_gt(v));
    // `above` is −1 where t > v: a saturating add steps those lanes down by one.
    t.saturating_add(above)
}

/// [`cell_of`] of two corners in one lane floor (the same cells: [`floor_lanes`] is
/// [`floor_i32`] lane-wise).
#[inline(always)]
pub(super) fn box_cells(lo: Vec3, hi: Vec3, inv_cell: f32) -> ([i32; 3], [i32; 3]) {
    let v = f32x8::from([lo.x, lo.y, lo.z, hi.x, hi.y, hi.z, 0.0, 0.0]) * f32x8::splat(inv_cell);
    let c = floor_lanes(v).to_array();
    ([c[0], c[1], c[2]], [c[3], c[4], c[5]])
}

/// [`bucket`] of eight points given as x, y, z lanes (the same buckets,
/// [`SKIPPED`] for a point with a NaN coordinate).
#[inline(always)]
pub(super) fn lane_buckets([x, y, z]: [f32x8; 3], inv_cell: f32, layout: Layout) -> [u32; LANES] {
    let inv = f32x8::splat(inv_cell);
    let c = [
        floor_lanes(x * inv),
        floor_lanes(y * inv),
        floor_lanes(z * inv),
    ];
    let h = c[0] + c[1] * i32x8::splat(layout.p2 as i32) + c[2] * i32x8::splat(layout.p3 as i32);
    let h = h & i32x8::splat(layout.mask as i32);
    let nan: i32x8 = wide::bytemuck::cast(x.is_nan() | y.is_nan() | z.is_nan());
    nan.select(i32x8::splat(SKIPPED as i32), h)
        .to_array()
        .map(|b| b as u32)
}

/// Counts each bucket of `buckets` in `start[b + 2]` (the counting sort's first pass).
pub(super) fn count_buckets(start: &mut [u32], buckets: &[u32]) {
    for &b in buckets {
        if b != SKIPPED {
            start[b as usize + 2] += 1;
        }
    }
}

/// In-place inclusive prefix sum plus `acc`, one entry at a time (the scalar reference
/// of [`prefix_sum_lanes`]).
pub(super) fn prefix_sum(c: &mut [u32], mut acc: u32) {
    for v in c {
        acc += *v;
        *v = acc;
    }
}

/// Inclusive scan of eight entries in place, plus `carry` (every lane holds the total of
/// the entries before them); returns the new carry.
#[inline(always)]
pub(super) fn scan8(g: &mut [u32], carry: u32x8) -> u32x8 {
    let mut v = u32x8::from(<[u32; LANES]>::try_from(&*g).expect("eight entries"));
    let a = v.to_array();
    v += u32x8::from([0, a[0], a[1], a[2], a[3], a[4], a[5], a[6]]);
    let a = v.to_array();
    v += u32x8::from([0, 0, a[0], a[1], a[2], a[3], a[4], a[5]]);
    let a = v.to_array();
    v += u32x8::from([0, 0, 0, 0, a[0], a[1], a[2], a[3]]);
    let a = (v + carry).to_array();
    g.copy_from_slice(&a);
    u32x8::splat(a[LANES - 1])
}

/// [`prefix_sum`] eight entries at a time: an in-register scan (three shifted adds)
/// plus the running total. The entries are cut into [`SCAN_STREAMS`] spans whose totals
/// are summed first, so the spans are then scanned interleaved, each with its own
/// running total: the carry from group to group no longer bounds the loop.
pub(super) fn prefix_sum_lanes(c: &mut [u32]) {
    let span = c.len() / (SCAN_STREAMS * LANES) * LANES;
    if span == 0 {
        return prefix_sum(c, 0);
    }
    let mut carry = [u32x8::splat(0); SCAN_STREAMS];
    let mut total = 0u32;
    for (k, part) in c.chunks_exact(span).take(SCAN_STREAMS).enumerate() {
        carry[k] = u32x8::splat(total);
        total += part.iter().sum::<u32>();
    }
    let (spans, tail) = c.split_at_mut(span * SCAN_STREAMS);
    let mut parts = spans.chunks_exact_mut(span);
    let mut parts: [&mut [u32]; SCAN_STREAMS] =
        std::array::from_fn(|_| parts.next().expect("SCAN_STREAMS spans"));
    for g in (0..span).step_by(LANES) {
        for (part, carry) in parts.iter_mut().zip(&mut carry) {
            *carry = scan8(&mut part[g..g + LANES], *carry);
        }
    }
    prefix_sum(tail, total);
}

/// Spans scanned side by side by [`prefix_sum_lanes`].
pub(super) const SCAN_STREAMS: usize = 4;

/// The bucket of point `p` ([`hash`] of [`cell_of`]), [`SKIPPED`] for a NaN coordinate.
#[inline(always)]
pub(super) fn bucket(p: Vec3, inv_cell: f32, layout: Layout) -> u32 {
    if p.is_nan() {
        SKIPPED
    } else {
        hash(cell_of(p, inv_cell), layout) as u32
    }
}

/// The bounding box of the points of the columns `x`, `y`, `z` that have no NaN
/// coordinate (`None` if there is none), eight points at a time: the same box as a fold
/// of `Vec3::min` and `Vec3::max` over those points (minima and maxima do not round).
pub(super) fn lane_bounds(x: &[f32], y: &[f32], z: &[f32]) -> Option<(Vec3, Vec3)> {
    let n = x.len();
    let whole = n / LANES * LANES;
    let (inf, ninf) = (f32x8::splat(f32::INFINITY), f32x8::splat(f32::NEG_INFINITY));
    let mut lo = [inf; 3];
    let mut hi = [ninf; 3];
    for at in (0..whole).step_by(LANES) {
        let c = [load8(x, at), load8(y, at), load8(z, at)];
        let nan = c[0].is_nan() | c[1].is_nan() | c[2].is_nan();
        for a in 0..3 {
            lo[a] = lo[a].min(nan.select(inf, c[a]));
            hi[a] = hi[a].max(nan.select(ninf, c[a]));
        }
    }
    let fold = |v: [f32x8; 3], f: fn(f32, f32) -> f32| {
        Vec3::from_array(v.map(|l| l.to_array().into_iter().reduce(f).expect("lanes")))
    };
    let mut b = (fold(lo, f32::min), fold(hi, f32::max));
    for i in whole..n {
        let p = Vec3::new(x[i], y[i], z[i]);
        if !p.is_nan() {
            b = (b.0.min(p), b.1.max(p));
        }
    }
    (b.0.x <= b.1.x).then_some(b)
}

/// Point `i` at `(x, y, z)` as one 16-byte record: the index and the coordinates' bits.
#[inline(always)]
pub(super) fn pack(i: usize, x: f32, y: f32, z: f32) -> [u64; 2] {
    let word = |lo: u32, hi: f32| lo as u64 | (hi.to_bits() as u64) << 32;
    [word(i as u32, x), word(y.to_bits(), z)]
}

/// The index and coordinates of a [`pack`]ed record, bit for bit.
#[inline(always)]
pub(super) fn unpack([a, b]: [u64; 2]) -> (u32, f32, f32, f32) {
    let hi = |w: u64| f32::from_bits((w >> 32) as u32);
    (a as u32, hi(a), f32::from_bits(b as u32), hi(b))
}

/// Additive spatial hash: consecutive x cells map to consecutive buckets (mod table).
/// It is linear modulo the table size, so whether two cells collide depends only on
/// their offset (see [`row_separation`]).
#[inline(always)]
pub(super) fn hash(c: [i32; 3], layout: Layout) -> usize {
    let h = (c[0] as u32)
        .wrapping_add((c[1] as u32).wrapping_mul(layout.p2))
        .wrapping_add((c[2] as u32).wrapping_mul(layout.p3));
    h as usize & layout.mask
}

/// `sep[a][b]`: the smallest circular distance, modulo the table size `mask + 1`,
/// between the first buckets of two distinct rows of an `(a + 1) × (b + 1)`-row query
/// box. Rows of `nx` cells occupy the buckets `b₀..b₀ + nx`, so no two rows of such a box
/// share a bucket iff `nx ≤ sep[a][b]`. Since the hash is linear, the distance for the
/// row offset `(dy, dz)` is that of `p2·dy + p3·dz`, whatever the box's position.
pub(super) fn row_separation(layout: Layout) -> [[u32; SEP]; SEP] {
    let Layout { mask, p2, p3 } = layout;
    let table = mask as u64 + 1;
    let dist = |dy: i32, dz: i32| -> u32 {
        let v = (dy as u32)
            .wrapping_mul(p2)
            .wrapping_add((dz as u32).wrapping_mul(p3)) as usize
            & mask;
        (v as u64).min(table - v as u64).min(u32::MAX as u64) as u32
    };
    // m[dy][|dz|]: offsets (dy, ±dz) up to sign, i.e. dy > 0, or dy = 0 and dz > 0.
    let mut sep = [[u32::MAX; SEP]; SEP];
    for dy in 0..SEP {
        for dz in 0..SEP {
            let (a, b) = (dy as i32, dz as i32);
            let mut d = if dy > 0 {
                dist(a, b).min(dist(a, -b))
            } else if dz > 0 {
                dist(0, b)
            } else {
                u32::MAX
            };
            // Prefix minimum: every offset with |dy'| ≤ dy and |dz'| ≤ dz.
            if dy > 0 {
                d = d.min(sep[dy - 1][dz]);
            }
            if dz > 0 {
                d = d.min(sep[dy][dz - 1]);
            }
            sep[dy][dz] = d;
        }
    }
    sep
}
