//! Uniform spatial hash grid (Teschner et al. 2003), sorted by cell.
//!
//! Points are binned into cubic cells of edge `cell`; cells are hashed into a table of
//! about twice the point count, and a counting sort makes each bucket's points
//! contiguous, so building is linear and a range query touches only a few short runs.

use glam::Vec3;

/// Spatial hash of a point set, rebuilt in linear time.
#[derive(Clone, Debug, Default)]
pub struct Grid {
    cell: f32,
    inv_cell: f32,
    mask: usize,
    /// `start[b]..start[b + 1]` indexes `sorted` for bucket `b`.
    start: Vec<u32>,
    /// Point indices sorted by bucket.
    sorted: Vec<u32>,
    /// Copies of the points in sorted order (cache-friendly distance tests).
    px: Vec<f32>,
    py: Vec<f32>,
    pz: Vec<f32>,
}

#[inline]
fn cell_of(p: Vec3, inv_cell: f32) -> [i32; 3] {
    [
        (p.x * inv_cell).floor() as i32,
        (p.y * inv_cell).floor() as i32,
        (p.z * inv_cell).floor() as i32,
    ]
}

#[inline]
fn hash(c: [i32; 3], mask: usize) -> usize {
    let h = (c[0] as u32).wrapping_mul(73_856_093)
        ^ (c[1] as u32).wrapping_mul(19_349_663)
        ^ (c[2] as u32).wrapping_mul(83_492_791);
    h as usize & mask
}

impl Grid {
    /// Builds the grid of `points` with cell edge `cell` (> 0, finite).
    pub fn build(points: impl ExactSizeIterator<Item = Vec3> + Clone, cell: f32) -> Self {
        assert!(cell.is_finite() && cell > 0.0, "grid cell size must be > 0");
        let n = points.len();
        let table = (2 * n).next_power_of_two().max(16);
        let mask = table - 1;
        let inv_cell = 1.0 / cell;
        let mut count = vec![0u32; table + 1];
        let buckets: Vec<u32> = points
            .clone()
            .map(|p| hash(cell_of(p, inv_cell), mask) as u32)
            .collect();
        for &b in &buckets {
            count[b as usize + 1] += 1;
        }
        for b in 0..table {
            count[b + 1] += count[b];
        }
        let start = count.clone();
        let mut fill = count;
        let mut sorted = vec![0u32; n];
        for (i, &b) in buckets.iter().enumerate() {
            let slot = &mut fill[b as usize];
            sorted[*slot as usize] = i as u32;
            *slot += 1;
        }
        let pts: Vec<Vec3> = points.collect();
        let px = sorted.iter().map(|&i| pts[i as usize].x).collect();
        let py = sorted.iter().map(|&i| pts[i as usize].y).collect();
        let pz = sorted.iter().map(|&i| pts[i as usize].z).collect();
        Self {
            cell,
            inv_cell,
            mask,
            start,
            sorted,
            px,
            py,
            pz,
        }
    }

    /// Cell edge length.
    pub fn cell(&self) -> f32 {
        self.cell
    }

    /// Number of points in the grid.
    pub fn len(&self) -> usize {
        self.sorted.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sorted.is_empty()
    }

    /// Calls `f(index, squared_distance)` once for every point within `r` of `x`
    /// (`|p − x| ≤ r`), in no particular order.
    pub fn for_each_within(&self, x: Vec3, r: f32, mut f: impl FnMut(usize, f32)) {
        if self.sorted.is_empty() || r.is_nan() || r < 0.0 {
            return;
        }
        let r2 = r * r;
        let span = (2.0 * r * self.inv_cell + 2.0).min(1.0e6);
        if span * span * span > self.sorted.len() as f32 {
            // The query box covers more cells than there are points: a scan is cheaper.
            self.scan(x, r2, &mut f);
            return;
        }
        let lo = cell_of(x - Vec3::splat(r), self.inv_cell);
        let hi = cell_of(x + Vec3::splat(r), self.inv_cell);
        // Distinct cells can share a bucket; visit each bucket once.
        let mut seen_small = [usize::MAX; 64];
        let mut seen_big: Vec<usize> = Vec::new();
        let cells = (hi[0] - lo[0] + 1) as usize
            * (hi[1] - lo[1] + 1) as usize
            * (hi[2] - lo[2] + 1) as usize;
        let mut n_seen = 0;
        for cz in lo[2]..=hi[2] {
            for cy in lo[1]..=hi[1] {
                for cx in lo[0]..=hi[0] {
                    let b = hash([cx, cy, cz], self.mask);
                    let dup = if cells <= seen_small.len() {
                        let d = seen_small[..n_seen].contains(&b);
                        if !d {
                            seen_small[n_seen] = b;
                            n_seen += 1;
                        }
                        d
                    } else {
                        let d = seen_big.contains(&b);
                        if !d {
                            seen_big.push(b);
                        }
                        d
                    };
                    if dup {
                        continue;
                    }
                    let (s, e) = (self.start[b] as usize, self.start[b + 1] as usize);
                    for k in s..e {
                        let dx = self.px[k] - x.x;
                        let dy = self.py[k] - x.y;
                        let dz = self.pz[k] - x.z;
                        let d2 = dx * dx + dy * dy + dz * dz;
                        if d2 <= r2 {
                            f(self.sorted[k] as usize, d2);
                        }
                    }
                }
            }
        }
    }

    fn scan(&self, x: Vec3, r2: f32, f: &mut impl FnMut(usize, f32)) {
        for k in 0..self.sorted.len() {
            let d2 = Vec3::new(self.px[k], self.py[k], self.pz[k]).distance_squared(x);
            if d2 <= r2 {
                f(self.sorted[k] as usize, d2);
            }
        }
    }

    /// The `k` nearest points to `x` as `(index, squared_distance)`, nearest first
    /// (ties broken by index). Fewer than `k` only when the grid holds fewer points.
    pub fn k_nearest(&self, x: Vec3, k: usize, out: &mut Vec<(usize, f32)>) {
        out.clear();
        let n = self.sorted.len();
        if n == 0 || k == 0 || !x.is_finite() {
            return;
        }
        let k = k.min(n);
        let mut r = self.cell;
        loop {
            out.clear();
            self.for_each_within(x, r, |i, d2| out.push((i, d2)));
            // Every point within r is found, so the k nearest are final once k lie within r.
            if out.len() >= k || out.len() == n {
                out.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
                out.truncate(k);
                return;
            }
            r *= 2.0;
        }
    }
}
