//! Uniform spatial hash grid (Teschner et al. 2003), sorted by cell.
//!
//! Points are binned into cubic cells of edge `cell`; cells are hashed into a table of
//! at least twice the point count, and a counting sort makes each bucket's points
//! contiguous, so building is linear and a range query touches only a few short runs.
//! When the points' bounding box holds no more cells than twice that table, the table
//! is *dense* instead: one bucket per cell of the box, in row-major order (see `Layout`),
//! so no cells collide and cells near in space are near in memory.
//!
//! Differences from the paper, for speed:
//! - the hash is *additive* in the cell's x index, `h(x, y, z) = x + p₂·y + p₃·z mod T`,
//!   so the cells of one x-row of a query box are consecutive buckets and their points
//!   one contiguous run of the sorted arrays: with `cell = r` a query reads 3 × 3 runs
//!   instead of 27 cells;
//! - the sorted coordinates are stored as separate `x`, `y`, `z` arrays and tested
//!   8 at a time (`wide::f32x8`); the hits go through a small on-stack buffer without
//!   data-dependent branches before being reported;
//! - queries are clipped to the cells of the points' bounding box;
//! - distinct cells that share a bucket: since the hash is linear, whether two rows of a
//!   query box share buckets depends only on the box's shape, which is checked against a
//!   small table made at build time. When they may, a point is reported only from the
//!   row of its own cell (recomputed per hit), so no query allocates or dedups buckets.
//!
//! [`Grid::rebuild`] reuses every allocation; with the point count not growing it does
//! not touch the heap, and neither do [`Grid::for_each_within`] and (given a reused
//! output vector) [`Grid::k_nearest`].
//!
//! Points with a NaN coordinate are skipped when building: they are never reported
//! (and [`Grid::indexed`] does not count them). Points with infinite coordinates are
//! kept and reported exactly when the test below holds (e.g. for an infinite radius).
//!
//! Reporting rule, shared by all queries: with `d = p − x` computed per coordinate in
//! f32, point `p` is within `r` of `x` iff `d.x*d.x + d.y*d.y + d.z*d.z <= r*r`
//! (evaluated in that order, in f32, no fused multiply–add). The grid reports exactly
//! those points, whatever the cell size, round-off at the boundary included: the cells
//! searched cover `r` plus a margin larger than that round-off.

mod lazy;
mod query;
#[cfg(test)]
mod tests;

pub use lazy::LazyGrid;

use crate::columns::Vec3s;
use glam::Vec3;
use wide::{f32x8, i32x8, u32x8};

/// SIMD width of the distance tests.
const LANES: usize = 8;
const _: () = assert!(LANES == 8, "push_lanes expands two nibbles");

/// Lanes `at..at + LANES` of a padded coordinate array.
#[inline(always)]
fn load8(s: &[f32], at: usize) -> f32x8 {
    let a: [f32; LANES] = s[at..at + LANES].try_into().expect("padded coordinates");
    f32x8::from(a)
}

/// Spatial hash of a point set, rebuilt in linear time.
#[derive(Clone, Debug, Default)]
pub struct Grid {
    cell: f32,
    inv_cell: f32,
    /// How cells map to buckets (table size, multipliers).
    layout: Layout,
    /// The cells of the indexed points' bounding box, corners included: queries are
    /// clipped to it (no point lies outside).
    bounds: [[i32; 3]; 2],
    /// Number of points given to the last build (indices are below this).
    n_input: usize,
    /// `start[b]..start[b + 1]` indexes the sorted arrays for bucket `b`
    /// (`mask + 3` entries; the last one is scratch of the counting sort).
    start: Vec<u32>,
    /// Point indices sorted by bucket (NaN points left out).
    sorted: Vec<u32>,
    /// Copies of the points in sorted order (cache-friendly distance tests), followed by
    /// `LANES - 1` padding entries.
    px: Vec<f32>,
    py: Vec<f32>,
    pz: Vec<f32>,
    /// Query boxes with `ny × nz` rows and at most `row_sep[ny − 1][nz − 1]` cells per row
    /// have no two rows sharing a bucket (see [`row_separation`]).
    row_sep: [[u32; SEP]; SEP],
    /// Build scratch: the bucket of every input point ([`SKIPPED`] for NaN points).
    bucket_of: Vec<u32>,
    /// Build scratch of [`Grid::rebuild_columns`]: every point as a [`pack`]ed record,
    /// in sorted order.
    records: Vec<[u64; 2]>,
    /// Build scratch of [`Grid::rebuild_subset`]: the subset's coordinates as columns.
    subset_pos: Vec3s,
}

/// What a range query reads (see [`Grid::plan`]).
enum Query {
    /// Nothing can match (empty grid, NaN input, negative radius).
    Nothing,
    /// Every point: the box would cover more cells than there are points.
    Scan { r2: f32 },
    /// The rows `(cy, cz)` of the cell box `lo..=hi`, `nx` cells each; `shared` when two
    /// rows may share a bucket (points are then reported only from their own row).
    Rows {
        lo: [i32; 3],
        hi: [i32; 3],
        nx: usize,
        shared: bool,
        r2: f32,
    },
}

/// Capacity of the per-query hit buffer (a power of two, at least 2 × LANES). Small
/// enough that clearing it per query is a few stores, not a `memset` call (128 was).
const HITS: usize = 64;
/// Most sorted positions in one batch of [`Grid::for_each_hit_batch`].
pub const HIT_BATCH: usize = HITS;

/// `NIBBLE_LANES[m]`: the set bits of the 4-bit mask `m`, in increasing order (the
/// entries past its popcount are don't-cares).
const NIBBLE_LANES: [[u32; 4]; 16] = {
    let mut t = [[0u32; 4]; 16];
    let mut m = 0;
    while m < 16 {
        let (mut c, mut l) = (0, 0);
        while l < 4 {
            if (m >> l) & 1 == 1 {
                t[m][c] = l as u32;
                c += 1;
            }
            l += 1;
        }
        m += 1;
    }
    t
};

/// Sorted positions that passed the distance test, awaiting report (on the stack).
struct Hits {
    pos: [u32; HITS],
    len: usize,
}

impl Hits {
    #[inline(always)]
    fn new() -> Self {
        Self {
            pos: [0; HITS],
            len: 0,
        }
    }

    /// Appends `base + l` for every set bit `l` of the `LANES`-bit `mask`, without
    /// branches: each half of the mask is expanded by a table lookup and stored whole,
    /// and the length advances by its popcount. Needs `len ≤ HITS − LANES`.
    #[inline(always)]
    fn push_lanes(&mut self, base: u32, mask: u32) {
        debug_assert!(self.len <= HITS - LANES);
        let lo = (mask & 15) as usize;
        let hi = ((mask >> 4) & 15) as usize;
        // The clamps are no-ops given the precondition; they drop the bounds checks.
        let at = self.len.min(HITS - LANES);
        for (w, &l) in self.pos[at..at + 4].iter_mut().zip(&NIBBLE_LANES[lo]) {
            *w = base + l;
        }
        let at = (at + lo.count_ones() as usize).min(HITS - 4);
        for (w, &l) in self.pos[at..at + 4].iter_mut().zip(&NIBBLE_LANES[hi]) {
            *w = base + 4 + l;
        }
        self.len = at + hi.count_ones() as usize;
    }
}

/// Largest query box, in rows per axis, covered by [`row_separation`].
const SEP: usize = 8;

/// Hash multipliers of the y and z cell indices (Teschner et al.'s primes), for point
/// sets whose bounding box holds too many cells for a dense table (see [`Layout`]).
const P2: u32 = 19_349_663;
const P3: u32 = 83_492_791;

/// A dense table may have up to this many times the buckets of the hashed one (which
/// has at least twice the point count): the 1M `scale` scene's contact-region grid (83k
/// surfels, 350k cells in its box) ran 1–13% faster dense than hashed, and a factor of 4
/// gained nothing more (measured on that scene with `phyxel run scale`).
const DENSE_TABLE_FACTOR: u64 = 2;

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
struct Layout {
    /// Table size minus one (the table size is a power of two).
    mask: usize,
    p2: u32,
    p3: u32,
}

impl Layout {
    /// Buckets of the hashed table for `n` points: at least twice the point count.
    fn hashed_table(n: usize) -> usize {
        (2 * n).next_power_of_two().max(16)
    }

    /// The layout for `n` points whose cells span `lo..=hi` (`None`: no indexable point).
    fn new(n: usize, bounds: Option<[[i32; 3]; 2]>) -> Self {
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
const SKIPPED: u32 = u32::MAX;

/// `floor(v)` as an `i32`, saturating at the `i32` range, 0 for NaN. Monotone in `v`.
///
/// Written out because without SSE4.1 (the default x86-64 target) `f32::floor` is a
/// libm call; the grid uses this one function for building and querying alike, so
/// cell assignment is consistent by construction.
#[inline(always)]
fn floor_i32(v: f32) -> i32 {
    let t = v as i32; // truncates toward zero, saturates, NaN → 0
    if (t as f32) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

#[inline(always)]
fn cell_of(p: Vec3, inv_cell: f32) -> [i32; 3] {
    [
        floor_i32(p.x * inv_cell),
        floor_i32(p.y * inv_cell),
        floor_i32(p.z * inv_cell),
    ]
}

/// [`floor_i32`] of eight values: the same saturation (`trunc_int` saturates like `as`,
/// NaN → 0) and the same step down where truncation rounded up.
#[inline(always)]
fn floor_lanes(v: f32x8) -> i32x8 {
    let t = v.trunc_int();
    let above: i32x8 = wide::bytemuck::cast(t.round_float().simd_gt(v));
    // `above` is −1 where t > v: a saturating add steps those lanes down by one.
    t.saturating_add(above)
}

/// [`cell_of`] of two corners in one lane floor (the same cells: [`floor_lanes`] is
/// [`floor_i32`] lane-wise).
#[inline(always)]
fn box_cells(lo: Vec3, hi: Vec3, inv_cell: f32) -> ([i32; 3], [i32; 3]) {
    let v = f32x8::from([lo.x, lo.y, lo.z, hi.x, hi.y, hi.z, 0.0, 0.0]) * f32x8::splat(inv_cell);
    let c = floor_lanes(v).to_array();
    ([c[0], c[1], c[2]], [c[3], c[4], c[5]])
}

/// [`bucket`] of eight points given as x, y, z lanes (the same buckets,
/// [`SKIPPED`] for a point with a NaN coordinate).
#[inline(always)]
fn lane_buckets([x, y, z]: [f32x8; 3], inv_cell: f32, layout: Layout) -> [u32; LANES] {
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
fn count_buckets(start: &mut [u32], buckets: &[u32]) {
    for &b in buckets {
        if b != SKIPPED {
            start[b as usize + 2] += 1;
        }
    }
}

/// In-place inclusive prefix sum plus `acc`, one entry at a time (the scalar reference
/// of [`prefix_sum_lanes`]).
fn prefix_sum(c: &mut [u32], mut acc: u32) {
    for v in c {
        acc += *v;
        *v = acc;
    }
}

/// Inclusive scan of eight entries in place, plus `carry` (every lane holds the total of
/// the entries before them); returns the new carry.
#[inline(always)]
fn scan8(g: &mut [u32], carry: u32x8) -> u32x8 {
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
fn prefix_sum_lanes(c: &mut [u32]) {
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
const SCAN_STREAMS: usize = 4;

/// The bucket of point `p` ([`hash`] of [`cell_of`]), [`SKIPPED`] for a NaN coordinate.
#[inline(always)]
fn bucket(p: Vec3, inv_cell: f32, layout: Layout) -> u32 {
    if p.is_nan() {
        SKIPPED
    } else {
        hash(cell_of(p, inv_cell), layout) as u32
    }
}

/// The bounding box of the points of the columns `x`, `y`, `z` that have no NaN
/// coordinate (`None` if there is none), eight points at a time: the same box as a fold
/// of `Vec3::min` and `Vec3::max` over those points (minima and maxima do not round).
fn lane_bounds(x: &[f32], y: &[f32], z: &[f32]) -> Option<(Vec3, Vec3)> {
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
fn pack(i: usize, x: f32, y: f32, z: f32) -> [u64; 2] {
    let word = |lo: u32, hi: f32| lo as u64 | (hi.to_bits() as u64) << 32;
    [word(i as u32, x), word(y.to_bits(), z)]
}

/// The index and coordinates of a [`pack`]ed record, bit for bit.
#[inline(always)]
fn unpack([a, b]: [u64; 2]) -> (u32, f32, f32, f32) {
    let hi = |w: u64| f32::from_bits((w >> 32) as u32);
    (a as u32, hi(a), f32::from_bits(b as u32), hi(b))
}

/// Additive spatial hash: consecutive x cells map to consecutive buckets (mod table).
/// It is linear modulo the table size, so whether two cells collide depends only on
/// their offset (see [`row_separation`]).
#[inline(always)]
fn hash(c: [i32; 3], layout: Layout) -> usize {
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
fn row_separation(layout: Layout) -> [[u32; SEP]; SEP] {
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

impl Grid {
    /// Builds the grid of `points` with cell edge `cell` (> 0, finite).
    ///
    /// Equivalent to [`Grid::default`] followed by [`Grid::rebuild`].
    pub fn build(points: impl ExactSizeIterator<Item = Vec3> + Clone, cell: f32) -> Self {
        let mut g = Self::default();
        g.rebuild(points, cell);
        g
    }

    /// Rebuilds the grid in place over `points` with cell edge `cell` (> 0, finite),
    /// in linear time, reusing the existing buffers: no heap allocation unless the
    /// point count exceeds every earlier build's.
    ///
    /// `points` is iterated three times. Points with a NaN coordinate are skipped (never
    /// reported); indices reported by queries are positions in `points`.
    ///
    /// For fixed-radius queries of radius `r`, `cell = r` is a good choice (a query
    /// reads 3 × 3 runs of 3 cells each).
    ///
    /// One point at a time: this is also the scalar reference of
    /// [`Grid::rebuild_columns`], which builds the same grid bit for bit.
    pub fn rebuild(&mut self, points: impl ExactSizeIterator<Item = Vec3> + Clone, cell: f32) {
        let n = points.len();
        let bounds = points
            .clone()
            .filter(|p| !p.is_nan())
            .fold(None, |b: Option<(Vec3, Vec3)>, p| {
                Some(b.map_or((p, p), |(lo, hi)| (lo.min(p), hi.max(p))))
            });
        let table = self.begin(n, cell, bounds);
        let (inv_cell, layout) = (self.inv_cell, self.layout);
        // The counts go through a local slice, not `self`: stores through `self`'s vectors
        // would make the compiler reload every vector's pointer and length per point.
        let start = &mut self.start[..];
        self.bucket_of.clear();
        self.bucket_of.extend(points.clone().map(|p| {
            let b = bucket(p, inv_cell, layout);
            if b != SKIPPED {
                start[b as usize + 2] += 1;
            }
            b
        }));
        prefix_sum(&mut start[..table + 2], 0);
        self.scatter(points, table);
    }

    /// [`Grid::rebuild`] over SoA columns: the buckets eight points at a time, straight
    /// from the columns, the counting sort's prefix sum eight buckets at a time, and a
    /// scatter of packed records (see `scatter_packed`). The grid is the same as
    /// [`Grid::rebuild`] of `pos.iter()`, bit for bit.
    pub fn rebuild_columns(&mut self, pos: &Vec3s, cell: f32) {
        let n = pos.len();
        let (x, y, z) = (&pos.x[..n], &pos.y[..n], &pos.z[..n]);
        let table = self.begin(n, cell, lane_bounds(x, y, z));
        let (inv_cell, layout) = (self.inv_cell, self.layout);
        self.bucket_of.resize(n, 0);
        let whole = n / LANES * LANES;
        let start = &mut self.start[..];
        let (lanes, tail) = self.bucket_of.split_at_mut(whole);
        for (k, out) in lanes.chunks_exact_mut(LANES).enumerate() {
            let at = k * LANES;
            let b = lane_buckets([load8(x, at), load8(y, at), load8(z, at)], inv_cell, layout);
            out.copy_from_slice(&b);
            count_buckets(start, &b);
        }
        for (i, out) in (whole..n).zip(&mut *tail) {
            *out = bucket(Vec3::new(x[i], y[i], z[i]), inv_cell, layout);
        }
        count_buckets(start, tail);
        prefix_sum_lanes(&mut start[..table + 2]);
        self.scatter_packed(pos, table);
    }

    /// [`Grid::scatter`] in two passes: each point goes to its slot as one [`pack`]ed
    /// record (two stores instead of four scattered ones), then a sequential pass, which
    /// the compiler vectorizes, unpacks the records into `sorted`, `px`, `py`, `pz`.
    /// Once the buckets come in lanes the scattered stores are most of the build, and
    /// halving them is what pays (the scalar build, bound by its bucket pass, gains
    /// nothing from it: docs/PERFORMANCE.md).
    fn scatter_packed(&mut self, pos: &Vec3s, table: usize) {
        let n = pos.len();
        let (x, y, z) = (&pos.x[..n], &pos.y[..n], &pos.z[..n]);
        let m = self.start[table + 1] as usize;
        self.resize_sorted(m);
        self.records.resize(m, [0; 2]);
        let (start, records) = (&mut self.start[..], &mut self.records[..m]);
        for (i, &b) in self.bucket_of[..n].iter().enumerate() {
            if b == SKIPPED {
                continue;
            }
            let slot = &mut start[b as usize + 1];
            let s = *slot as usize;
            *slot += 1;
            records[s] = pack(i, x[i], y[i], z[i]);
        }
        let (sorted, px, py, pz) = (
            &mut self.sorted[..m],
            &mut self.px[..m],
            &mut self.py[..m],
            &mut self.pz[..m],
        );
        for (k, &r) in records.iter().enumerate() {
            (sorted[k], px[k], py[k], pz[k]) = unpack(r);
        }
        debug_assert_eq!(start[table], start[table + 1]);
    }

    /// Sizes the sorted arrays for `m` points, the coordinates padded so that SIMD
    /// loads of a run's last lanes stay in bounds.
    fn resize_sorted(&mut self, m: usize) {
        self.sorted.resize(m, 0);
        self.px.resize(m + LANES - 1, 0.0);
        self.py.resize(m + LANES - 1, 0.0);
        self.pz.resize(m + LANES - 1, 0.0);
    }

    /// Sets the cell size and the table for `n` points and clears the bucket counts;
    /// returns the table size.
    fn begin(&mut self, n: usize, cell: f32, bounds: Option<(Vec3, Vec3)>) -> usize {
        assert!(cell.is_finite() && cell > 0.0, "grid cell size must be > 0");
        assert!(n < u32::MAX as usize, "too many points for a grid");
        self.cell = cell;
        self.inv_cell = 1.0 / cell;
        // `floor` is monotone, so the corners' cells bound every point's cell.
        let cells = bounds.map(|(lo, hi)| [cell_of(lo, self.inv_cell), cell_of(hi, self.inv_cell)]);
        let layout = Layout::new(n, cells);
        let table = layout.mask + 1;
        if self.layout != layout || self.start.is_empty() {
            self.row_sep = row_separation(layout);
        }
        self.layout = layout;
        // No point: an empty box that clips every query.
        self.bounds = cells.unwrap_or([[0; 3], [-1; 3]]);
        self.n_input = n;
        // Counting sort by bucket: `start[b + 2]` counts bucket `b` (filled by the
        // caller), so that after the prefix sum `start[b + 1]` is where bucket `b`
        // begins ...
        self.start.clear();
        // Room for the largest table `n` points can take, so that a later build of as
        // many points with another box does not allocate.
        self.start
            .reserve(DENSE_TABLE_FACTOR as usize * Layout::hashed_table(n) + 2);
        self.start.resize(table + 2, 0);
        table
    }

    /// The counting sort's scatter, after the bucket pass and the prefix sum: `points`
    /// again, in the order the buckets were computed.
    fn scatter(&mut self, points: impl Iterator<Item = Vec3>, table: usize) {
        let m = self.start[table + 1] as usize;
        self.resize_sorted(m);
        // ... and after the scatter `start[b]` is where bucket `b` begins. (Local slices,
        // so that the four stores per point do not force reloads of `self`.)
        let (start, sorted) = (&mut self.start[..], &mut self.sorted[..m]);
        let (px, py, pz) = (&mut self.px[..m], &mut self.py[..m], &mut self.pz[..m]);
        for ((i, p), &b) in points.enumerate().zip(&self.bucket_of) {
            if b == SKIPPED {
                continue;
            }
            let slot = &mut start[b as usize + 1];
            let s = *slot as usize;
            *slot += 1;
            (sorted[s], px[s], py[s], pz[s]) = (i as u32, p.x, p.y, p.z);
        }
        debug_assert_eq!(start[table], start[table + 1]);
    }

    /// Rebuilds the grid over the points `subset` of `pos` only, reporting them by their
    /// index in `pos`: a grid of the part of an object that queries can reach (e.g. near
    /// a contact) costs that part's size, not the object's. Does not allocate when
    /// `subset` does not grow.
    ///
    /// The subset's coordinates are first copied into columns the grid keeps, so that
    /// the build runs in lanes ([`Grid::rebuild_columns`]).
    pub fn rebuild_subset(&mut self, pos: &Vec3s, subset: &[u32], cell: f32) {
        let mut columns = std::mem::take(&mut self.subset_pos);
        columns.gather_from(pos, subset);
        self.rebuild_columns(&columns, cell);
        self.subset_pos = columns;
        for s in &mut self.sorted {
            *s = subset[*s as usize];
        }
        self.n_input = pos.len();
    }

    /// Cell edge length.
    pub fn cell(&self) -> f32 {
        self.cell
    }

    /// Number of points given to the last build (including skipped NaN points):
    /// reported indices are below this.
    pub fn len(&self) -> usize {
        self.n_input
    }

    /// True when the last build was given no points.
    pub fn is_empty(&self) -> bool {
        self.n_input == 0
    }

    /// Number of points actually indexed: [`Grid::len`] minus those with a NaN coordinate.
    pub fn indexed(&self) -> usize {
        self.sorted.len()
    }
}
