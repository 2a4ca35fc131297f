//! The kernel sums of the implicit surface eight surfels at a time: `exp(−q)` lane-wise,
//! the surfel columns in a grid's sorted order, and the lane sums.

use super::*;

/// `exp(−q)` lane-wise for `q ≥ 0` (lanes beyond ~87 give 0 or garbage that the caller
/// masks): `n = round(−q log₂e)`, `r = −q − n ln2` with ln2 split in two (Cody–Waite, so
/// r carries no rounding of the product), `e^r` by a degree-6 Taylor polynomial
/// (|r| ≤ ln2/2: relative error < 2e-7) and `2ⁿ` from the exponent bits. Only adds,
/// multiplies and bit operations: fast without SSE4.1 or FMA.
#[inline(always)]
pub fn exp_neg(q: f32x8) -> f32x8 {
    use wide::bytemuck::cast;
    use wide::i32x8;
    const MAGIC: f32 = 12_582_912.0; // 1.5 · 2²³: adding it rounds to an integer
    const LN2_HI: f32 = 0.693_359_4; // few mantissa bits: n · LN2_HI is exact
    const LN2_LO: f32 = -2.121_944_4e-4;
    let c = f32x8::splat;
    let x = (-q).max(c(-87.0));
    let t = x * c(std::f32::consts::LOG2_E) + c(MAGIC);
    let n = t - c(MAGIC);
    let r = (x - n * c(LN2_HI)) - n * c(LN2_LO);
    let p = c(1.0)
        + r * (c(1.0)
            + r * (c(0.5)
                + r * (c(1.0 / 6.0)
                    + r * (c(1.0 / 24.0) + r * (c(1.0 / 120.0) + r * c(1.0 / 720.0))))));
    // n sits in the low mantissa bits of t; 2ⁿ has the exponent field n + 127.
    let n_bits = cast::<f32x8, i32x8>(t) - cast::<f32x8, i32x8>(c(MAGIC));
    let scale: f32x8 = cast((n_bits + i32x8::splat(127)) << 23);
    p * scale
}

/// The surfels' normals and kernel widths σ (as `1/σ²`) in a grid's sorted order, as columns
/// padded by `LANES − 1` like the grid's own sorted positions: the kernel sums then
/// read every surfel datum in whole lane groups, next to the grid's distance test, with
/// no gather per hit. Rebuilt after each grid rebuild (surfels move); keeps its buffers.
#[derive(Clone, Debug, Default)]
pub struct SurfelRows {
    normal: [Vec<f32>; 3],
    /// `1/σ²`: the weight's exponent is a product, not a division (∞ for a zero radius).
    inv_sigma2: Vec<f32>,
    /// Per grid bucket, the widest cutoff `CUTOFF_SIGMAS σ` of its surfels (m): a query
    /// reads only as far as the kernels near it reach ([`SurfelRows::reach_near`]).
    bucket_reach: Vec<f32>,
    /// Whether some surfel's kernel reaches less than 3/4 as far as the widest: only
    /// then does reading the buckets near a query pay ([`SurfelRows::reach_near`]).
    graded: bool,
}

impl SurfelRows {
    /// Columns of `grid`'s points (`pos`, the positions it was built over, whose
    /// `normal` and `radius` these are) in its sorted order.
    pub fn rebuild(&mut self, grid: &Grid, pos: &Vec3s, normal: &Vec3s, radius: &[f32]) {
        debug_assert_eq!(grid.len(), pos.len());
        let sorted = grid.sorted();
        // One pass over the sorted order, the four columns side by side: each surfel's
        // data is read once, and nothing is called through a pointer per element.
        let len = sorted.len() + LANES - 1;
        let [nx, ny, nz] = &mut self.normal;
        for col in [&mut *nx, &mut *ny, &mut *nz, &mut self.inv_sigma2] {
            col.clear();
            col.resize(len, 0.0);
        }
        let columns = nx.iter_mut().zip(ny.iter_mut()).zip(nz.iter_mut());
        let (mut narrowest, mut widest) = (0.0f32, f32::INFINITY);
        for ((((x, y), z), w), &i) in columns.zip(self.inv_sigma2.iter_mut()).zip(sorted) {
            let i = i as usize;
            (*x, *y, *z) = (normal.x[i], normal.y[i], normal.z[i]);
            let sigma = SIGMA_PER_RADIUS * radius[i];
            *w = 1.0 / (sigma * sigma);
            if w.is_finite() {
                (narrowest, widest) = (narrowest.max(*w), widest.min(*w));
            }
        }
        // Kernels 3/4 as wide (1/σ² 16/9 as large) or more: the query reads its reach.
        self.graded = narrowest > 16.0 / 9.0 * widest;
        self.bucket_reach.clear();
        if !self.graded {
            return;
        }
        let starts = grid.bucket_starts();
        let inv_sigma2 = &self.inv_sigma2;
        self.bucket_reach.extend(starts.windows(2).map(|b| {
            let widest = inv_sigma2[b[0] as usize..b[1] as usize]
                .iter()
                .fold(f32::INFINITY, |a, &w| a.min(w));
            // ∞ (an empty bucket, or zero radii) reaches nothing. Widened past the
            // rounding of `add`'s cutoff test.
            CUTOFF_SIGMAS / widest.sqrt() * (1.0 + 1.0e-5)
        }));
    }

    /// How far from `x` a kernel of `grid`'s surfels (those these rows were rebuilt
    /// from) can weigh: the widest cutoff among the surfels a query of radius `reach`
    /// (every kernel's cutoff or more) would read, at most `reach` (`reach` itself when
    /// the kernels differ little). A graded surface's fine region is read as far as its
    /// own kernels reach, not its coarse ones': the sums are the same, since a surfel
    /// beyond its own cutoff weighs nothing.
    #[inline]
    pub fn reach_near(&self, grid: &Grid, x: Vec3, reach: f32) -> f32 {
        if !self.graded {
            return reach;
        }
        grid.max_over_query_buckets(x, reach, &self.bucket_reach)
            .map_or(reach, |r| r.min(reach))
    }
}

/// `Σθ`, `Σθ s` and `Σθ n` as lane sums: each lane group of a query adds its eight
/// weights (zero outside its mask and beyond the cutoff) times the eight surfels'
/// data, and the lanes are added up once at the end.
#[derive(Clone, Copy, Default)]
pub(super) struct LaneSums {
    w: f32x8,
    s: [f32x8; 3],
    n: [f32x8; 3],
}

impl LaneSums {
    /// Adds the surfels at sorted positions `k..k + 8` whose bit is set in `mask`,
    /// with squared distances `d2` (the grid's sorted positions `points`).
    #[inline(always)]
    pub(super) fn add(
        &mut self,
        points: [&[f32]; 3],
        rows: &SurfelRows,
        k: usize,
        mask: u32,
        d2: f32x8,
    ) {
        let q = d2 * load8(&rows.inv_sigma2, k);
        // Beyond the cutoff (and ∞ or NaN from a zero radius) weigh 0.
        let on = lane_mask(mask) & q.simd_lt(f32x8::splat(CUTOFF_SIGMAS * CUTOFF_SIGMAS));
        // A group wholly beyond its kernels adds nothing: on a graded body most groups
        // of a fine region lie within the coarse kernels' reach but beyond their own.
        if on.none() {
            return;
        }
        let w = on.select(exp_neg(q), f32x8::ZERO);
        self.w += w;
        for ((s, n), (p, nc)) in self
            .s
            .iter_mut()
            .zip(&mut self.n)
            .zip(points.iter().zip(&rows.normal))
        {
            *s = w.mul_add(load8(p, k), *s);
            *n = w.mul_add(load8(nc, k), *n);
        }
    }

    /// The squared distances to `x` of the points at sorted positions `k..k + 8` (the
    /// grid's f32 operations, hence its values).
    #[inline(always)]
    pub(super) fn d2(points: [&[f32]; 3], k: usize, x: Vec3) -> f32x8 {
        let d = |a: usize, c: f32| load8(points[a], k) - f32x8::splat(c);
        let (dx, dy, dz) = (d(0, x.x), d(1, x.y), d(2, x.z));
        dx * dx + dy * dy + dz * dz
    }

    /// `(Σθ, Σθ s, Σθ n)`.
    pub(super) fn totals(&self) -> (f32, Vec3, Vec3) {
        let v = |l: [f32x8; 3]| Vec3::new(l[0].reduce_add(), l[1].reduce_add(), l[2].reduce_add());
        (self.w.reduce_add(), v(self.s), v(self.n))
    }
}
