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

mod cells;
mod lazy;
mod query;
#[cfg(test)]
mod tests;

pub use lazy::LazyGrid;

use crate::columns::Vec3s;
use cells::{
    DENSE_TABLE_FACTOR, Layout, SEP, SKIPPED, bucket, cell_of, count_buckets, lane_bounds,
    lane_buckets, pack, prefix_sum, prefix_sum_lanes, row_separation, unpack,
};
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
/// enough that clearing it per query is a few stores, not a `memset` call (as at 128).
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
