//! Queries of a built grid: every point within a radius (scalar, batched and lane-wide
//! sums), and nearest neighbours.

use super::*;
use cells::{SEP, box_cells, cell_of, floor_i32, hash};

impl Grid {
    /// Calls `f(index, squared_distance)` once for every point within `r` of `x`
    /// (`|p − x|² ≤ r²` evaluated in f32 as described in the module docs), in no
    /// particular order. Nothing is reported for a NaN `x`, a NaN or negative `r`, or a
    /// NaN point. Does not allocate.
    #[inline]
    pub fn for_each_within(&self, x: Vec3, r: f32, mut f: impl FnMut(usize, f32)) {
        self.for_each_hit_batch(x, r, |batch| {
            for &j in batch {
                let j = j as usize;
                // The same f32 operations as the lane tests, hence the same value.
                let (dx, dy, dz) = (self.px[j] - x.x, self.py[j] - x.y, self.pz[j] - x.z);
                f(self.sorted[j] as usize, dx * dx + dy * dy + dz * dz);
            }
        });
    }

    /// True when a point lies within `r` of `x` (the set [`Grid::for_each_within`]
    /// reports is not empty); stops at the first lane group with a hit.
    pub fn any_within(&self, x: Vec3, r: f32) -> bool {
        let xs = [x.x, x.y, x.z].map(f32x8::splat);
        let any_in = |s: u32, e: u32, r2: f32| {
            let r2s = f32x8::splat(r2);
            (s as usize..e as usize)
                .step_by(LANES)
                .any(|k| self.lane_distances(k, e as usize, xs, r2s).0 != 0)
        };
        match self.plan::<true>(x, r) {
            Query::Nothing => false,
            Query::Scan { r2 } => any_in(0, self.sorted.len() as u32, r2),
            // A point met through a shared bucket is still within `r`: no row filter.
            Query::Rows { lo, hi, nx, r2, .. } => (lo[2]..=hi[2]).any(|cz| {
                (lo[1]..=hi[1]).any(|cy| {
                    self.row_runs(lo[0], nx, cy, cz)
                        .into_iter()
                        .any(|(s, e)| any_in(s, e, r2))
                })
            }),
        }
    }

    /// Scalar reference of [`Grid::for_each_within`]: the same cells, points and f32
    /// distance test, one point at a time and in order (no lanes), so the scalar
    /// references of the SIMD kernels are scalar throughout. Does not allocate.
    pub(crate) fn for_each_within_scalar(&self, x: Vec3, r: f32, mut f: impl FnMut(usize, f32)) {
        let mut test = |k: usize, r2: f32, row: Option<(i32, i32)>| {
            let (dx, dy, dz) = (self.px[k] - x.x, self.py[k] - x.y, self.pz[k] - x.z);
            let d2 = dx * dx + dy * dy + dz * dz;
            let own_row = row.is_none_or(|(cy, cz)| self.in_row(k, cy, cz));
            if d2 <= r2 && own_row {
                f(self.sorted[k] as usize, d2);
            }
        };
        match self.plan::<false>(x, r) {
            Query::Nothing => {}
            Query::Scan { r2 } => (0..self.sorted.len()).for_each(|k| test(k, r2, None)),
            Query::Rows {
                lo,
                hi,
                nx,
                shared,
                r2,
            } => self.box_runs(lo, hi, nx, |s, e, cy, cz| {
                let row = shared.then_some((cy, cz));
                (s as usize..e as usize).for_each(|k| test(k, r2, row));
            }),
        }
    }

    /// The points within `r` of `x` (the set [`Grid::for_each_within`] reports) as
    /// batches of *sorted positions* (they index [`Grid::sorted`] and
    /// [`Grid::sorted_points`]), at most [`HIT_BATCH`] per call: kernels that keep their
    /// own data in the grid's order read it without the indirection. Does not allocate.
    #[inline]
    pub fn for_each_hit_batch(&self, x: Vec3, r: f32, mut f: impl FnMut(&[u32])) {
        let (lo, hi, nx, shared, r2) = match self.plan::<true>(x, r) {
            Query::Nothing => return,
            Query::Scan { r2 } => {
                let mut hits = Hits::new();
                self.run::<false>(0, self.sorted.len() as u32, 0, 0, x, r2, &mut hits, &mut f);
                self.flush::<false>(&mut hits, 0, 0, &mut f);
                return;
            }
            Query::Rows {
                lo,
                hi,
                nx,
                shared,
                r2,
            } => (lo, hi, nx, shared, r2),
        };
        let mut hits = Hits::new();
        if !shared {
            // No two rows of this box share a bucket: every point is met at most once.
            for cz in lo[2]..=hi[2] {
                for cy in lo[1]..=hi[1] {
                    for (s, e) in self.row_runs(lo[0], nx, cy, cz) {
                        self.run::<false>(s, e, cy, cz, x, r2, &mut hits, &mut f);
                    }
                }
            }
            self.flush::<false>(&mut hits, 0, 0, &mut f);
        } else {
            // Rows may share buckets: report a point only from the row of its own cell.
            for cz in lo[2]..=hi[2] {
                for cy in lo[1]..=hi[1] {
                    for (s, e) in self.row_runs(lo[0], nx, cy, cz) {
                        self.run::<true>(s, e, cy, cz, x, r2, &mut hits, &mut f);
                    }
                    self.flush::<true>(&mut hits, cy, cz, &mut f);
                }
            }
        }
    }

    /// What a query of radius `r` around `x` reads: nothing, a scan of every point, or
    /// the rows of a box of cells (whose corners' cells take one lane floor, or with
    /// `LANE_FLOOR` false six scalar ones: the same cells).
    #[inline(always)]
    fn plan<const LANE_FLOOR: bool>(&self, x: Vec3, r: f32) -> Query {
        let m = self.sorted.len();
        if m == 0 || r.is_nan() || r < 0.0 || x.is_nan() {
            return Query::Nothing;
        }
        let r2 = r * r;
        // The box searched is widened past `r` by more than the f32 round-off of the
        // distance test (relative 2⁻²² plus underflow), so it holds every point the test
        // accepts; the rounding of `x ± reach` itself only widens the box.
        let reach = r * (1.0 + 1.0e-6) + 1.0e-20;
        let (lo, hi) = if LANE_FLOOR {
            box_cells(
                x - Vec3::splat(reach),
                x + Vec3::splat(reach),
                self.inv_cell,
            )
        } else {
            (
                cell_of(x - Vec3::splat(reach), self.inv_cell),
                cell_of(x + Vec3::splat(reach), self.inv_cell),
            )
        };
        if r2 == f32::INFINITY {
            // An infinite `r²` accepts points at any distance, so the box is no bound.
            return Query::Scan { r2 };
        }
        // No point lies outside the bounding box's cells: the box is clipped to them.
        let [blo, bhi] = self.bounds;
        let lo: [i32; 3] = std::array::from_fn(|a| lo[a].max(blo[a]));
        let hi: [i32; 3] = std::array::from_fn(|a| hi[a].min(bhi[a]));
        if (0..3).any(|a| lo[a] > hi[a]) {
            return Query::Nothing;
        }
        let nx = hi[0] as i64 - lo[0] as i64 + 1;
        let ny = hi[1] as i64 - lo[1] as i64 + 1;
        let nz = hi[2] as i64 - lo[2] as i64 + 1;
        let cells = nx.saturating_mul(ny).saturating_mul(nz);
        if cells > m as i64 {
            // The query box covers more cells than there are points: a scan is cheaper.
            return Query::Scan { r2 };
        }
        // Here nx ≤ cells ≤ m < table size, so one row never reaches a bucket twice.
        let nx = nx as usize;
        let (ny, nz) = (ny as usize, nz as usize);
        let shared = !(ny <= SEP && nz <= SEP && nx <= self.row_sep[ny - 1][nz - 1] as usize);
        Query::Rows {
            lo,
            hi,
            nx,
            shared,
            r2,
        }
    }

    /// The sorted-position runs of row `(cy, cz)`, cells `x0..x0 + nx`: the row's cells
    /// are the consecutive buckets `b0..b0 + nx` (mod table size), so one or two runs
    /// (the second empty when the row does not wrap).
    #[inline(always)]
    fn row_runs(&self, x0: i32, nx: usize, cy: i32, cz: i32) -> [(u32, u32); 2] {
        let table = self.layout.mask + 1;
        // One bounds check here instead of one per lookup: `b0 ≤ mask` and, in the first
        // arm, `b1 ≤ table`.
        let start = &self.start[..=table];
        let b0 = hash([x0, cy, cz], self.layout);
        let b1 = b0 + nx;
        if b1 <= table {
            [(start[b0], start[b1]), (0, 0)]
        } else {
            [(start[b0], start[table]), (start[0], start[b1 - table])]
        }
    }

    /// True when the point at sorted position `k` lies in cell row `(cy, cz)`: the
    /// filter of queries whose rows share buckets.
    #[inline(always)]
    fn in_row(&self, k: usize, cy: i32, cz: i32) -> bool {
        floor_i32(self.py[k] * self.inv_cell) == cy && floor_i32(self.pz[k] * self.inv_cell) == cz
    }

    /// The sorted-position runs of the query box `lo..=hi` (rows of `nx` cells), row by
    /// row: `f(s, e, cy, cz)` for each run `s..e` of row `(cy, cz)`.
    #[inline(always)]
    fn box_runs(
        &self,
        lo: [i32; 3],
        hi: [i32; 3],
        nx: usize,
        mut f: impl FnMut(u32, u32, i32, i32),
    ) {
        for cz in lo[2]..=hi[2] {
            for cy in lo[1]..=hi[1] {
                for (s, e) in self.row_runs(lo[0], nx, cy, cz) {
                    f(s, e, cy, cz);
                }
            }
        }
    }

    /// Squared distances of the lane group at sorted position `k` to `x` (splat in
    /// `xs`), and the bit mask of the lanes within `r²` that lie before `e`. The
    /// coordinate arrays are padded by `LANES − 1`, so lanes past `e` exist.
    #[inline(always)]
    fn lane_distances(&self, k: usize, e: usize, xs: [f32x8; 3], r2s: f32x8) -> (u32, f32x8) {
        // Sliced to what the run `..e` may load, so that with `k < e` the loads need no
        // bounds checks of their own.
        let end = e + LANES - 1;
        let (px, py, pz) = (&self.px[..end], &self.py[..end], &self.pz[..end]);
        let dx = load8(px, k) - xs[0];
        let dy = load8(py, k) - xs[1];
        let dz = load8(pz, k) - xs[2];
        let d2 = dx * dx + dy * dy + dz * dz;
        let mut mask = d2.simd_le(r2s).to_bitmask();
        if e - k < LANES {
            mask &= (1u32 << (e - k)) - 1;
        }
        (mask, d2)
    }

    /// Collects the sorted positions `s..e` that pass the distance test into `hits`
    /// (branch-free: the hits of a lane group are appended whatever their number).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn run<const FILTER: bool>(
        &self,
        s: u32,
        e: u32,
        cy: i32,
        cz: i32,
        x: Vec3,
        r2: f32,
        hits: &mut Hits,
        f: &mut impl FnMut(&[u32]),
    ) {
        let (s, e) = (s as usize, e as usize);
        let xs = [x.x, x.y, x.z].map(f32x8::splat);
        let r2s = f32x8::splat(r2);
        let mut k = s;
        while k < e {
            let (mask, _) = self.lane_distances(k, e, xs, r2s);
            if hits.len > HITS - LANES {
                self.flush::<FILTER>(hits, cy, cz, f);
            }
            hits.push_lanes(k as u32, mask);
            k += LANES;
        }
    }

    /// Reports the collected hits and empties `hits`. With `FILTER`, only points of
    /// row `(cy, cz)` are reported.
    #[inline(always)]
    fn flush<const FILTER: bool>(
        &self,
        hits: &mut Hits,
        cy: i32,
        cz: i32,
        f: &mut impl FnMut(&[u32]),
    ) {
        let mut n = hits.len;
        if FILTER {
            n = 0;
            for k in 0..hits.len {
                let j = hits.pos[k];
                if self.in_row(j as usize, cy, cz) {
                    hits.pos[n] = j;
                    n += 1;
                }
            }
        }
        if n > 0 {
            f(&hits.pos[..n]);
        }
        hits.len = 0;
    }

    /// Point indices in the grid's sorted order (position `k` of [`Grid::sorted_points`]
    /// is input point `sorted()[k]`). Kernels that keep their own columns in this order
    /// read whole lanes with [`Grid::for_each_lanes_within`].
    pub fn sorted(&self) -> &[u32] {
        &self.sorted
    }

    /// The points' x, y, z in sorted order, each followed by `LANES − 1` padding entries.
    pub fn sorted_points(&self) -> [&[f32]; 3] {
        [&self.px, &self.py, &self.pz]
    }

    /// Visits the points within `r` of `x` a lane group at a time, in sorted order:
    /// `f(at, mask, d2)` where bit `l` of `mask` is set for each sorted position
    /// `at + l` within `r`, and lane `l` of `d2` is its squared distance (the same f32
    /// value [`Grid::for_each_within`] reports). Every point within `r` is in exactly one
    /// call with its bit set; lanes with a clear bit may be padding and must be ignored.
    pub fn for_each_lanes_within(&self, x: Vec3, r: f32, mut f: impl FnMut(usize, u32, f32x8)) {
        match self.plan::<true>(x, r) {
            Query::Nothing => {}
            Query::Scan { r2 } => {
                self.lanes::<false>(0, self.sorted.len() as u32, 0, 0, x, r2, &mut f)
            }
            Query::Rows {
                lo,
                hi,
                nx,
                shared,
                r2,
            } => self.box_runs(lo, hi, nx, |s, e, cy, cz| {
                if shared {
                    self.lanes::<true>(s, e, cy, cz, x, r2, &mut f);
                } else {
                    self.lanes::<false>(s, e, cy, cz, x, r2, &mut f);
                }
            }),
        }
    }

    /// The largest `per_bucket[b]` over the buckets of the cells that a query of
    /// radius `r` at `x` reads ([`Grid::for_each_lanes_within`]), so over every point
    /// that query could report; `None` when it reads no cell or scans every point.
    /// `per_bucket` has one entry per bucket ([`Grid::bucket_starts`]).
    pub fn max_over_query_buckets(&self, x: Vec3, r: f32, per_bucket: &[f32]) -> Option<f32> {
        let Query::Rows { lo, hi, .. } = self.plan::<true>(x, r) else {
            return None;
        };
        let mut most = 0.0f32;
        let nx = (hi[0] - lo[0]) as usize + 1;
        for cz in lo[2]..=hi[2] {
            for cy in lo[1]..=hi[1] {
                // A row's cells are consecutive buckets (see `row_runs`).
                let b0 = hash([lo[0], cy, cz], self.layout);
                for b in b0..b0 + nx {
                    most = most.max(per_bucket[b & self.layout.mask]);
                }
            }
        }
        Some(most)
    }

    /// Where each bucket's points lie in the sorted order: bucket `b` holds sorted
    /// positions `starts[b]..starts[b + 1]` (one entry more than there are buckets).
    pub fn bucket_starts(&self) -> &[u32] {
        &self.start[..self.layout.mask + 2]
    }

    /// The lane groups of sorted positions `s..e` with their distance masks; with
    /// `FILTER`, only points whose cell is in row `(cy, cz)` (rows sharing buckets).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn lanes<const FILTER: bool>(
        &self,
        s: u32,
        e: u32,
        cy: i32,
        cz: i32,
        x: Vec3,
        r2: f32,
        f: &mut impl FnMut(usize, u32, f32x8),
    ) {
        let (s, e) = (s as usize, e as usize);
        let xs = [x.x, x.y, x.z].map(f32x8::splat);
        let r2s = f32x8::splat(r2);
        let mut k = s;
        while k < e {
            let (mut mask, d2) = self.lane_distances(k, e, xs, r2s);
            if FILTER {
                for l in 0..LANES {
                    let j = k + l;
                    if mask & (1 << l) != 0 && !self.in_row(j, cy, cz) {
                        mask &= !(1 << l);
                    }
                }
            }
            if mask != 0 {
                f(k, mask, d2);
            }
            k += LANES;
        }
    }

    /// The nearest indexed point to `x` and its squared distance, without allocating:
    /// the search radius doubles from a third of a cell until a point lies within it
    /// (every point within r is found, so the nearest of them is final).
    pub fn nearest(&self, x: Vec3) -> Option<(usize, f32)> {
        if self.sorted.is_empty() || !x.is_finite() {
            return None;
        }
        // A third of a cell first: that box spans 1–2 cells per axis instead of 3, and
        // a point on a sampled surface has its nearest sample within it.
        let mut r = self.cell / 3.0;
        loop {
            let mut best: Option<(usize, f32)> = None;
            self.for_each_within(x, r, |i, d2| {
                if best.is_none_or(|(j, b)| (d2, i) < (b, j)) {
                    best = Some((i, d2));
                }
            });
            if best.is_some() || r == f32::INFINITY {
                return best;
            }
            r *= 2.0;
        }
    }

    /// The `k` nearest points to `x` as `(index, squared_distance)`, nearest first
    /// (ties broken by index). Fewer than `k` only when the grid indexes fewer points.
    /// Empty for a non-finite `x`. Allocates only if `out` must grow.
    pub fn k_nearest(&self, x: Vec3, k: usize, out: &mut Vec<(usize, f32)>) {
        self.k_nearest_from(x, k, self.cell, out);
    }

    /// [`Grid::k_nearest`] whose search starts at radius `r0` (doubling until `k` points
    /// lie within): the same result for any `r0`, only the work differs. A caller that
    /// knows about where the k-th neighbour lies (the last query's, for a coherent
    /// sequence of points) avoids both the doublings and a radius far too large.
    pub fn k_nearest_from(&self, x: Vec3, k: usize, r0: f32, out: &mut Vec<(usize, f32)>) {
        out.clear();
        let m = self.sorted.len();
        if m == 0 || k == 0 || !x.is_finite() {
            return;
        }
        let k = k.min(m);
        // Squared distances here are ≥ +0 and not NaN, so their bits order like their
        // values; indices are < 2³², so this key orders by (distance, index).
        let key = |e: &(usize, f32)| ((e.1.to_bits() as u64) << 32) | e.0 as u64;
        let mut r = if r0 > 0.0 && r0.is_finite() {
            r0
        } else {
            self.cell
        };
        loop {
            out.clear();
            self.for_each_within(x, r, |i, d2| out.push((i, d2)));
            // Every point within r is found, so the k nearest are final once k lie within
            // r. An infinite r finds every indexed point (x is finite, none is NaN).
            if out.len() >= k || r == f32::INFINITY {
                if out.len() > k {
                    out.select_nth_unstable_by_key(k - 1, key);
                    out.truncate(k);
                }
                out.sort_unstable_by_key(key);
                return;
            }
            r *= 2.0;
        }
    }
}
