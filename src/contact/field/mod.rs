//! The surface field of a surfel set: the paper's implicit surface (Keiser et al. 2004,
//! eq. 1, after Alexa et al.):
//! `a(x) = Σθ_k s_k / Σθ_k`, `n(x) = normalize(Σθ_k n_k)`, `f(x) = n(x)·(x − a(x))`,
//! with truncated Gaussian weights `θ_k = exp(−|x − s_k|²/σ_k²)` for
//! `|x − s_k| < 2.5 σ_k`, whose width `σ_k` is the surfel's disk radius, so it follows the local spacing.
//! A point is inside when `(x − x_proj)·n(x_proj) < 0` (eq. 2).

mod lanes;

use lanes::LaneSums;
pub use lanes::{SurfelRows, exp_neg};

use crate::columns::{LANES, Vec3s, lane_mask, load8};
use crate::spatial::broad_phase::Aabb;
use crate::spatial::grid::{Grid, LazyGrid};
use glam::Vec3;
use std::sync::atomic::{AtomicBool, Ordering};
use wide::f32x8;

/// Kernel width σ_k in units of the surfel's disk radius.
pub const SIGMA_PER_RADIUS: f32 = 1.0;
/// Truncation of the Gaussian in units of σ.
pub const CUTOFF_SIGMAS: f32 = 2.5;
/// Surfels used when none lies within the cutoff (points far from the surface).
pub const FAR_NEIGHBOURS: usize = 8;

thread_local! {
    /// k-nearest scratch of the far-field path, reused by each worker thread.
    static KNN_SCRATCH: std::cell::RefCell<Vec<(usize, f32)>> = const {
        std::cell::RefCell::new(Vec::new())
    };
    /// Distance of the last far-field query's k-th neighbour on this thread: where the
    /// next search starts (a worker's points are consecutive surfels, so nearby). Only
    /// the work depends on it, not the result.
    static FAR_RADIUS: std::cell::Cell<f32> = const { std::cell::Cell::new(0.0) };
}

/// The far-field k-nearest search starts this much beyond the last query's k-th
/// distance, so that a neighbour at about the same depth needs no second pass.
const FAR_RADIUS_SLACK: f32 = 1.2;
/// The search from a [`FarHint`] starts this much beyond the hinted radius: a surfel's
/// depth changes by a small fraction of itself per step.
const FAR_HINT_SLACK: f32 = 1.05;

/// Where a point's far-field nearest-surfel search should start: the distance of the
/// [`FAR_NEIGHBOURS`]-th nearest surfel found for (about) the same point before, e.g. the
/// same colliding surfel one step earlier; 0 when unknown. Only the work depends on it,
/// not the result ([`Grid::k_nearest_from`] is exact from any start).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FarHint(pub f32);

/// Most lane groups [`NearHits`] keeps (a kernel query meets about 10 at the paper's
/// sampling).
pub const NEAR_HITS: usize = 48;
/// How far from a kept query's centre its hits still serve, in kernel reaches.
pub const NEAR_HITS_SLACK: f32 = 0.02;

/// The lane groups with hits (sorted grid position and hit mask) of the last query of
/// [`SurfaceField::sample_near_kept`], for samples close to it.
#[derive(Clone, Copy, Debug)]
pub struct NearHits {
    centre: Vec3,
    /// Number kept; above [`NEAR_HITS`] when none are (none yet, or too many).
    len: usize,
    groups: [(u32, u32); NEAR_HITS],
}

impl Default for NearHits {
    fn default() -> Self {
        Self {
            centre: Vec3::ZERO,
            len: usize::MAX,
            groups: [(0, 0); NEAR_HITS],
        }
    }
}

/// Iteration limit of the orthogonal projection.
pub const MAX_PROJECTION_ITERATIONS: u32 = 20;
/// A projection step that leaves every kernel's reach is halved up to this many times
/// (to a sixteenth) before the far field is sampled at its end.
pub const MAX_STEP_HALVINGS: u32 = 4;
/// The projection's step is `f/g`, with `g = ∂f/∂t` the slope of `f` along the normal
/// measured over the last step, when `g` lies in this range (`g` is 1 for a flat
/// surface of equal kernels); outside it, and on the first step, the plain step `f`.
pub const PROJECTION_SLOPE_RANGE: (f32, f32) = (0.2, 2.0);
/// The measured slope is used only when the normal turned by less than this cosine
/// over the last step (both steps then run along about the same line).
pub const PROJECTION_SLOPE_COS: f32 = 0.999;
/// Convergence tolerance of the projection, in units of the smallest σ.
pub const PROJECTION_TOLERANCE: f32 = 1.0e-4;
/// The projection's tolerance is at least this many f32 epsilons of the point's largest
/// coordinate: `f = n·(x − a)` takes `a` from sums of surfel positions, whose round-off
/// grows with the distance from the origin, so far from it `|f|` cannot fall below
/// [`PROJECTION_TOLERANCE`] σ and the projection would run to its iteration limit
/// (a sphere of 3.5 mm spacing 100 m out: 427 of 500 projections unconverged without
/// the floor). One epsilon lets all converge there; two leave a margin (`tests/contact/detect.rs`).
pub const PROJECTION_ROUNDOFF_EPS: f32 = 2.0;

/// Result of projecting a point onto the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// The projected point `x_proj` on the surface.
    pub point: Vec3,
    /// `n(x_proj)`.
    pub normal: Vec3,
    /// `(x − x_proj)·n(x_proj)`: negative inside (m).
    pub signed_distance: f32,
    pub iterations: u32,
    pub converged: bool,
    /// [`SurfaceField::sample_near`] at `point` (the projection's last sample; `None`
    /// when no kernel reaches `point`): callers that sample there again reuse it.
    pub near: Option<SurfaceSample>,
}

/// Length of the projection's next step along `−s.normal` from the sample `s`, given
/// the last step `(t, s0)`: the secant (Newton) step `f/g` with the slope
/// `g = (f0 − f)/t` when the normal held still and `g` is plausible, else `f`. Where
/// the kernels make `f` change slower than the distance along the normal (curved or
/// unevenly sampled surfaces, `g` about 0.5), plain steps shrink the residual only by
/// `1 − g` each; the secant step removes that linear part.
#[inline]
fn projection_step(s: &SurfaceSample, last: Option<(f32, SurfaceSample)>) -> f32 {
    let Some((t, s0)) = last else {
        return s.f;
    };
    let g = (s0.f - s.f) / t;
    let (lo, hi) = PROJECTION_SLOPE_RANGE;
    if t != 0.0 && s0.normal.dot(s.normal) > PROJECTION_SLOPE_COS && (lo..=hi).contains(&g) {
        s.f / g
    } else {
        s.f
    }
}

/// The surface field `f` of one object's surfels (the paper's implicit surface), backed
/// by its surfel grid.
#[derive(Clone, Copy)]
pub struct SurfaceField<'a> {
    pos: &'a Vec3s,
    normal: &'a Vec3s,
    radius: &'a [f32],
    grid: &'a Grid,
    /// Grid for points far from every kernel (a coarser grid of the same surfels keeps
    /// their nearest-surfel search short, built only if some point needs it); `grid`
    /// unless set.
    far: Option<&'a LazyGrid>,
    /// `grid`'s surfel columns, for the SIMD kernel sums over lane groups.
    rows: Option<&'a SurfelRows>,
    /// When `grid` indexes only the surfels in a box: see [`Region`].
    region: Option<Region<'a>>,
    /// Largest query radius: the widest kernel's cutoff.
    reach: f32,
    tolerance: f32,
}

/// The box whose surfels an [`SurfaceField`]'s grids index, and the grids of all
/// surfels for queries that reach out of it.
#[derive(Clone, Copy)]
struct Region<'a> {
    bounds: Aabb,
    /// Kernel grid of every surfel (built on first use).
    all: &'a LazyGrid,
    /// Coarse far-field grid of the surfels in `bounds` (built on first use).
    far: &'a LazyGrid,
    /// The surfels in `bounds`, which `grid` indexes.
    members: &'a [u32],
    /// Set when the surfels outside `bounds` may be stale and a query reached them
    /// ([`SurfaceField::with_stale_outside`]).
    missed: Option<&'a AtomicBool>,
}

impl Region<'_> {
    /// A query reaches the surfels outside the box: flags it when they may be stale.
    #[inline]
    fn leaves(&self) {
        if let Some(m) = self.missed {
            m.store(true, Ordering::Relaxed);
        }
    }
}

/// Is the ball of radius `r` around `x` inside `b`?
#[inline]
fn ball_inside(b: &Aabb, x: Vec3, r: f32) -> bool {
    (x - r).cmpge(b.min).all() && (x + r).cmple(b.max).all()
}

/// The surface near a point: `f(x)`, `n(x)` and `a(x)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSample {
    pub f: f32,
    pub normal: Vec3,
    pub average: Vec3,
}

/// `a = Σw s / Σw`, `n = normalize(Σw n)`, `f = n·(x − a)` from the weighted sums.
fn finish(x: Vec3, w_sum: f32, ws: Vec3, wn: Vec3) -> Option<SurfaceSample> {
    let average = ws / w_sum;
    let normal = wn.try_normalize()?;
    Some(SurfaceSample {
        f: normal.dot(x - average),
        normal,
        average,
    })
}

/// Smallest and largest of `radius` (∞ and 0 when empty).
pub fn radius_range(radius: &[f32]) -> (f32, f32) {
    radius.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &r| {
        (lo.min(r), hi.max(r))
    })
}

/// Cell of the far-field grid in cells of the kernel grid: a nearest-surfel search from
/// a few kernel reaches deep takes one or two coarse queries instead of thousands of
/// fine cells. A search's box holds `(2r + cell)²` of a surface sheet, so a cell much
/// wider than the search radius `r` (about the depth) scans surfels the ball misses: at
/// 1M surfels, 4 runs detection 4–7% faster than 8 and 9% faster than 2, as fast as 3
/// (docs/PERFORMANCE.md).
pub const FAR_GRID_FACTOR: f32 = 4.0;

/// Grid cell size that lets one 27-cell query cover every kernel of surfels of
/// disk radius up to `max_radius`.
pub fn grid_cell(max_radius: f32) -> f32 {
    CUTOFF_SIGMAS * SIGMA_PER_RADIUS * max_radius
}

impl<'a> SurfaceField<'a> {
    /// The surface of surfels (`pos`, `normal`, disk `radius`) indexed by `grid`
    /// (built over `pos`).
    pub fn new(pos: &'a Vec3s, normal: &'a Vec3s, radius: &'a [f32], grid: &'a Grid) -> Self {
        let (r_min, r_max) = radius_range(&radius[..pos.len()]);
        Self::with_radius_range(pos, normal, radius, grid, r_min, r_max)
    }

    /// As [`SurfaceField::new`] with the smallest and largest disk radius already
    /// known (a caller that keeps them saves a pass over every surfel).
    pub fn with_radius_range(
        pos: &'a Vec3s,
        normal: &'a Vec3s,
        radius: &'a [f32],
        grid: &'a Grid,
        r_min: f32,
        r_max: f32,
    ) -> Self {
        Self {
            pos,
            normal,
            radius,
            grid,
            far: None,
            rows: None,
            region: None,
            reach: grid_cell(r_max),
            tolerance: PROJECTION_TOLERANCE * SIGMA_PER_RADIUS * r_min.min(r_max),
        }
    }

    /// `grid` indexes only the surfels `members`, those inside `region`
    /// ([`Grid::rebuild_subset`]), and `far` is the coarse far-field grid
    /// ([`FAR_GRID_FACTOR`] cells) of the same ones, built on first use; queries whose
    /// ball leaves the box use `all`, a kernel grid of every surfel built on first use,
    /// or the far grid of [`SurfaceField::with_far_grid`]. Results are those of grids
    /// of every surfel.
    pub fn with_region(
        mut self,
        region: Aabb,
        members: &'a [u32],
        all: &'a LazyGrid,
        far: &'a LazyGrid,
    ) -> Self {
        self.region = Some(Region {
            bounds: region,
            all,
            far,
            members,
            missed: None,
        });
        self
    }

    /// The surfels outside the region may be stale (`World::lazy_advection`): a query
    /// that reaches them sets `missed` (its answer is then not to be used; the caller
    /// brings the surfels current and asks again). `None`: they are current.
    pub fn with_stale_outside(mut self, missed: Option<&'a AtomicBool>) -> Self {
        if let Some(r) = &mut self.region {
            r.missed = missed;
        }
        self
    }

    /// The grid that holds every surfel within `r` of `x`.
    #[inline]
    fn grid_for(&self, x: Vec3, r: f32) -> &'a Grid {
        match self.region {
            Some(g) if !ball_inside(&g.bounds, x, r) => {
                g.leaves();
                g.all.get(self.pos, self.grid.cell())
            }
            _ => self.grid,
        }
    }

    /// The [`FAR_NEIGHBOURS`] surfels nearest to `x`, into `near`: from the region's
    /// far grid when no surfel outside the region can be among them, else from the far
    /// grid of all surfels. The search starts from `hint` (see [`FarHint`]) when it has
    /// one, else from this thread's last far search; both learn this search's radius.
    fn far_neighbours(&self, x: Vec3, near: &mut Vec<(usize, f32)>, hint: &mut FarHint) {
        let r0 = if hint.0 > 0.0 {
            hint.0 * FAR_HINT_SLACK
        } else {
            FAR_RADIUS.get() * FAR_RADIUS_SLACK
        };
        self.far_neighbours_from(x, r0, near);
        if let Some(&(_, d2)) = near.last() {
            let r = d2.sqrt();
            FAR_RADIUS.set(r);
            hint.0 = r;
        }
    }

    /// [`SurfaceField::far_neighbours`] with the search starting at radius `r0`.
    fn far_neighbours_from(&self, x: Vec3, r0: f32, near: &mut Vec<(usize, f32)>) {
        if let Some(g) = self.region {
            let far = g
                .far
                .get_subset(self.pos, g.members, FAR_GRID_FACTOR * self.grid.cell());
            far.k_nearest_from(x, FAR_NEIGHBOURS, r0, near);
            let inside = near.len() == FAR_NEIGHBOURS
                && near
                    .last()
                    .is_some_and(|&(_, d2)| ball_inside(&g.bounds, x, d2.sqrt() * (1.0 + 1.0e-6)));
            if inside {
                return;
            }
            g.leaves();
        }
        let far = match self.far {
            Some(lazy) => lazy.get(self.pos, FAR_GRID_FACTOR * self.grid.cell()),
            None => self.grid_for(x, f32::INFINITY),
        };
        far.k_nearest_from(x, FAR_NEIGHBOURS, r0, near);
    }

    /// The surfel nearest to `x` and its squared distance.
    pub fn nearest(&self, x: Vec3) -> Option<(usize, f32)> {
        let Some(g) = self.region else {
            return self.grid.nearest(x);
        };
        // Exact when no surfel outside the box could be nearer.
        let found = self.grid.nearest(x);
        if found.is_some_and(|(_, d2)| ball_inside(&g.bounds, x, d2.sqrt() * (1.0 + 1.0e-6))) {
            return found;
        }
        g.leaves();
        g.all.get(self.pos, self.grid.cell()).nearest(x)
    }

    /// Uses `coarse` (built on demand over the same surfels, with cells
    /// [`FAR_GRID_FACTOR`] times the grid's) for points far from every kernel.
    pub fn with_far_grid(mut self, coarse: &'a LazyGrid) -> Self {
        self.far = Some(coarse);
        self
    }

    /// Evaluates the kernel sums with the SIMD lane-group kernel over `rows` (rebuilt from
    /// this surface's surfels after its grid's last rebuild).
    pub fn with_rows(mut self, rows: &'a SurfelRows) -> Self {
        self.rows = Some(rows);
        self
    }

    /// Largest distance at which a surfel's kernel still weighs (m).
    pub fn reach(&self) -> f32 {
        self.reach
    }

    /// `f`, `n`, `a` at `x` from the surfels within their kernels' reach; `None` when
    /// `x` is farther than that from every surfel (cheap: one grid query).
    pub fn sample_near(&self, x: Vec3) -> Option<SurfaceSample> {
        let (w_sum, ws, wn) = self.accumulate(x);
        if w_sum <= 1.0e-30 {
            return None;
        }
        finish(x, w_sum, ws, wn)
    }

    fn accumulate(&self, x: Vec3) -> (f32, Vec3, Vec3) {
        self.weighted_sums(x)
    }

    /// `(Σθ_k, Σθ_k s_k, Σθ_k n_k)` at `x` over the surfels within reach: the kernel
    /// sums of eq. 1. With [`SurfaceField::with_rows`] (and the query inside the
    /// grid's region) each lane group of the grid query that holds a hit becomes eight
    /// weights in `f32x8` lanes (`exp_neg`) and adds them, times the eight surfels'
    /// positions and normals, to lane sums. Otherwise each hit adds its weight on its
    /// own (the same sums as the scalar reference, over the lane query).
    pub fn weighted_sums(&self, x: Vec3) -> (f32, Vec3, Vec3) {
        let in_grid = self
            .region
            .is_none_or(|g| ball_inside(&g.bounds, x, self.reach));
        let Some(rows) = self.rows.filter(|_| in_grid) else {
            return self.sums_per_hit::<false>(x);
        };
        let points = self.grid.sorted_points();
        let mut sums = LaneSums::default();
        let reach = rows.reach_near(self.grid, x, self.reach);
        self.grid.for_each_lanes_within(x, reach, |k, mask, d2| {
            sums.add(points, rows, k, mask, d2);
        });
        sums.totals()
    }

    /// [`SurfaceField::sample_near`] that keeps the query's lane groups in `hits`
    /// for the next samples: one within [`NEAR_HITS_SLACK`] reaches of the last query's
    /// centre reads the kept groups instead of the grid (a root search's last
    /// evaluations lie within its tolerance of each other). Same weights and sums as
    /// `sample_near` up to summation order (`tests/contact/detect.rs`).
    pub fn sample_near_kept(&self, x: Vec3, hits: &mut NearHits) -> Option<SurfaceSample> {
        let slack = NEAR_HITS_SLACK * self.reach;
        let wide = self.reach + slack;
        let in_grid = self.region.is_none_or(|g| ball_inside(&g.bounds, x, wide));
        let Some(rows) = self.rows.filter(|_| in_grid) else {
            return self.sample_near(x);
        };
        let points = self.grid.sorted_points();
        let mut sums = LaneSums::default();
        if hits.len <= NEAR_HITS && (x - hits.centre).length_squared() <= slack * slack {
            for &(k, mask) in &hits.groups[..hits.len] {
                let k = k as usize;
                sums.add(points, rows, k, mask, LaneSums::d2(points, k, x));
            }
        } else {
            // The widest kernel that can weigh anywhere within the slack of `x`: the
            // groups kept hold every surfel within its reach of such a point. Hits beyond
            // `reach` weigh 0 here (beyond their cutoffs).
            let reach = rows.reach_near(self.grid, x, wide).min(self.reach);
            let mut len = 0;
            self.grid
                .for_each_lanes_within(x, reach + slack, |k, mask, d2| {
                    sums.add(points, rows, k, mask, d2);
                    if let Some(slot) = hits.groups.get_mut(len) {
                        *slot = (k as u32, mask);
                    }
                    len += 1;
                });
            hits.centre = x;
            hits.len = if len <= NEAR_HITS { len } else { usize::MAX };
        }
        let (w_sum, ws, wn) = sums.totals();
        if w_sum <= 1.0e-30 {
            return None;
        }
        finish(x, w_sum, ws, wn)
    }

    /// Scalar reference of [`SurfaceField::weighted_sums`] (tests and benches): the
    /// scalar grid query ([`Grid::for_each_within_scalar`]), libm `exp` and vector
    /// multiply-adds per hit, no lanes anywhere.
    pub(crate) fn weighted_sums_scalar(&self, x: Vec3) -> (f32, Vec3, Vec3) {
        self.sums_per_hit::<true>(x)
    }

    /// The kernel sums one hit at a time, over the scalar or the lane grid query.
    fn sums_per_hit<const SCALAR_QUERY: bool>(&self, x: Vec3) -> (f32, Vec3, Vec3) {
        let (mut w_sum, mut ws, mut wn) = (0.0f32, Vec3::ZERO, Vec3::ZERO);
        let add = |k: usize, d2: f32| {
            let sigma = SIGMA_PER_RADIUS * self.radius[k];
            let q = d2 / (sigma * sigma);
            if q < CUTOFF_SIGMAS * CUTOFF_SIGMAS {
                let w = (-q).exp();
                w_sum += w;
                ws += w * self.pos.get(k);
                wn += w * self.normal.get(k);
            }
        };
        let grid = self.grid_for(x, self.reach);
        if SCALAR_QUERY {
            grid.for_each_within_scalar(x, self.reach, add);
        } else {
            grid.for_each_within(x, self.reach, add);
        }
        (w_sum, ws, wn)
    }

    /// `f`, `n`, `a` at `x`; `None` only when the surface has no surfels.
    pub fn sample(&self, x: Vec3) -> Option<SurfaceSample> {
        self.sample_near(x).or_else(|| self.sample_far(x))
    }

    /// [`SurfaceField::sample`] at a point where [`SurfaceField::sample_near`] gave
    /// `near` (a caller that already has it saves the grid query).
    pub fn sample_given(&self, x: Vec3, near: Option<SurfaceSample>) -> Option<SurfaceSample> {
        near.or_else(|| self.sample_far(x))
    }

    /// Far from every kernel: weight the nearest surfels on their own scale.
    fn sample_far(&self, x: Vec3) -> Option<SurfaceSample> {
        self.sample_far_hinted(x, &mut FarHint::default())
    }

    /// [`SurfaceField::sample_far`] whose nearest-surfel search starts from `hint`,
    /// which learns the radius found.
    fn sample_far_hinted(&self, x: Vec3, hint: &mut FarHint) -> Option<SurfaceSample> {
        let (mut w_sum, mut ws, mut wn) = (0.0f32, Vec3::ZERO, Vec3::ZERO);
        // One scratch list per thread: the step stays free of heap allocation.
        KNN_SCRATCH.with_borrow_mut(|near| {
            self.far_neighbours(x, near, hint);
            let (_, d2_far) = *near.last()?;
            let (_, d2_near) = near[0];
            let s2 = d2_far.max(1e-30);
            for &(k, d2) in near.iter() {
                let w = (-(d2 - d2_near) / s2).exp();
                w_sum += w;
                ws += w * self.pos.get(k);
                wn += w * self.normal.get(k);
            }
            finish(x, w_sum, ws, wn)
        })
    }

    /// Orthogonal projection onto the surface: `x ← x − t n(x)` until `|f| < tolerance`
    /// ([`PROJECTION_TOLERANCE`] σ, at least [`PROJECTION_ROUNDOFF_EPS`] epsilons of
    /// `x`'s largest coordinate) or [`MAX_PROJECTION_ITERATIONS`], with `t = f(x)` on the
    /// first step and the secant step of [`PROJECTION_SLOPE_RANGE`] after a step between
    /// two kernel samples (far-field samples take the plain step); a step from within
    /// the kernels' reach that leaves it is halved, up to [`MAX_STEP_HALVINGS`] times.
    pub fn project(&self, x: Vec3) -> Option<Projection> {
        self.project_given(x, self.sample_near(x))
    }

    /// [`SurfaceField::project`] where [`SurfaceField::sample_near`] at `x` gave
    /// `near`: the same result without sampling `x` again.
    pub fn project_given(&self, x: Vec3, near: Option<SurfaceSample>) -> Option<Projection> {
        self.project_hinted(x, near, &mut FarHint::default())
    }

    /// [`SurfaceField::project_given`] whose far-field sample at `x` (if `x` is far
    /// from every kernel) starts its search from `hint` and leaves its radius there: the
    /// same result with less work when the hint is close.
    pub fn project_hinted(
        &self,
        x: Vec3,
        near: Option<SurfaceSample>,
        hint: &mut FarHint,
    ) -> Option<Projection> {
        let mut p = x;
        let mut near = near;
        let mut s = match near {
            Some(s) => s,
            None => self.sample_far_hinted(x, hint)?,
        };
        let tolerance = self
            .tolerance
            .max(PROJECTION_ROUNDOFF_EPS * f32::EPSILON * x.abs().max_element());
        let mut iterations = 0;
        let mut converged = s.f.abs() < tolerance;
        // The last steps are short: their samples read the previous query's hits.
        let mut kept = NearHits::default();
        // The last step's length and the sample it started from.
        let mut last: Option<(f32, SurfaceSample)> = None;
        while !converged && iterations < MAX_PROJECTION_ITERATIONS {
            let mut t = projection_step(&s, last);
            let mut next = p - t * s.normal;
            let from_near = near.is_some();
            near = self.sample_near_kept(next, &mut kept);
            // A step from within the kernels' reach that lands beyond all of them
            // overshot (a secant slope near its floor): shorten it rather than sample
            // the far field out there (a nearest-surfel search, the costliest sample).
            let mut halvings = 0;
            while from_near && near.is_none() && halvings < MAX_STEP_HALVINGS {
                t *= 0.5;
                next = p - t * s.normal;
                near = self.sample_near_kept(next, &mut kept);
                halvings += 1;
            }
            // Far-field samples (no kernel in reach) fit a plane to the nearest surfels,
            // which moves from one point to the next: their difference is no slope of
            // f, and a secant through it can throw the next step millimetres past the
            // surface. Only a step between two kernel samples gives the next a slope.
            last = (from_near && near.is_some()).then_some((t, s));
            p = next;
            s = self.sample_given(p, near)?;
            iterations += 1;
            converged = s.f.abs() < tolerance;
        }
        Some(Projection {
            point: p,
            normal: s.normal,
            signed_distance: (x - p).dot(s.normal),
            iterations,
            converged,
            near,
        })
    }

    /// Eq. (2): is `x` inside the surface? Also returns the projection.
    pub fn inside(&self, x: Vec3) -> Option<(bool, Projection)> {
        self.inside_given(x, self.sample_near(x))
    }

    /// [`SurfaceField::inside`] given [`SurfaceField::sample_near`] at `x`.
    pub fn inside_given(&self, x: Vec3, near: Option<SurfaceSample>) -> Option<(bool, Projection)> {
        self.inside_hinted(x, near, &mut FarHint::default())
    }

    /// [`SurfaceField::inside_given`] with the far-field search of
    /// [`SurfaceField::project_hinted`].
    pub fn inside_hinted(
        &self,
        x: Vec3,
        near: Option<SurfaceSample>,
        hint: &mut FarHint,
    ) -> Option<(bool, Projection)> {
        let p = self.project_hinted(x, near, hint)?;
        Some((p.signed_distance < 0.0, p))
    }
}
