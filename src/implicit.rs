//! Implicit surface of a surfel set (Keiser et al. 2004, eq. 1, after Alexa et al.):
//! `a(x) = Σθ_k s_k / Σθ_k`, `n(x) = normalize(Σθ_k n_k)`, `f(x) = n(x)·(x − a(x))`,
//! with truncated Gaussian weights `θ_k = exp(−|x − s_k|²/σ_k²)` for `|x − s_k| < 2.5 σ_k`,
//! whose width `σ_k` is the surfel's disk radius, so it follows the local spacing.
//! A point is inside when `(x − x_proj)·n(x_proj) < 0` (eq. 2).

use crate::columns::Vec3s;
use crate::grid::Grid;
use glam::Vec3;

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
}
/// Iteration limit of the orthogonal projection.
pub const MAX_PROJECTION_ITERATIONS: u32 = 20;
/// Convergence tolerance of the projection, in units of the smallest σ.
pub const PROJECTION_TOLERANCE: f32 = 1.0e-4;

/// The implicit surface of one object's surfels, backed by its surfel grid.
#[derive(Clone, Copy)]
pub struct ImplicitSurface<'a> {
    pos: &'a Vec3s,
    normal: &'a Vec3s,
    radius: &'a [f32],
    grid: &'a Grid,
    /// Grid for points far from every kernel (a coarser grid of the same surfels keeps
    /// their nearest-surfel search short); `grid` unless set.
    far: &'a Grid,
    /// Largest query radius: the widest kernel's cutoff.
    reach: f32,
    tolerance: f32,
}

/// The surface near a point: `f(x)`, `n(x)` and `a(x)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceSample {
    pub f: f32,
    pub normal: Vec3,
    pub average: Vec3,
}

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

/// Cell of the far-field grid in cells of the kernel grid: a nearest-surfel search from
/// a few kernel reaches deep takes one or two coarse queries instead of thousands of
/// fine cells.
pub const FAR_GRID_FACTOR: f32 = 8.0;

/// Grid cell size that lets one 27-cell query cover every kernel of surfels of
/// disk radius up to `max_radius`.
pub fn grid_cell(max_radius: f32) -> f32 {
    CUTOFF_SIGMAS * SIGMA_PER_RADIUS * max_radius
}

impl<'a> ImplicitSurface<'a> {
    /// The surface of surfels (`pos`, `normal`, disk `radius`) indexed by `grid`
    /// (built over `pos`).
    pub fn new(pos: &'a Vec3s, normal: &'a Vec3s, radius: &'a [f32], grid: &'a Grid) -> Self {
        let n = pos.len();
        let (r_min, r_max) = radius[..n]
            .iter()
            .fold((f32::INFINITY, 0.0f32), |(lo, hi), &r| {
                (lo.min(r), hi.max(r))
            });
        Self {
            pos,
            normal,
            radius,
            grid,
            far: grid,
            reach: grid_cell(r_max),
            tolerance: PROJECTION_TOLERANCE * SIGMA_PER_RADIUS * r_min.min(r_max),
        }
    }

    /// Uses `coarse` (a grid of the same surfels with larger cells) for points far from
    /// every kernel.
    pub fn with_far_grid(mut self, coarse: &'a Grid) -> Self {
        self.far = coarse;
        self
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
        let (mut w_sum, mut ws, mut wn) = (0.0f32, Vec3::ZERO, Vec3::ZERO);
        self.grid.for_each_within(x, self.reach, |k, d2| {
            let sigma = SIGMA_PER_RADIUS * self.radius[k];
            let q = d2 / (sigma * sigma);
            if q < CUTOFF_SIGMAS * CUTOFF_SIGMAS {
                let w = (-q).exp();
                w_sum += w;
                ws += w * self.pos.get(k);
                wn += w * self.normal.get(k);
            }
        });
        (w_sum, ws, wn)
    }

    /// `f`, `n`, `a` at `x`; `None` only when the surface has no surfels.
    pub fn sample(&self, x: Vec3) -> Option<SurfaceSample> {
        if let Some(s) = self.sample_near(x) {
            return Some(s);
        }
        // Far from every kernel: weight the nearest surfels on their own scale.
        let (mut w_sum, mut ws, mut wn) = (0.0f32, Vec3::ZERO, Vec3::ZERO);
        // One scratch list per thread: the step stays free of heap allocation.
        KNN_SCRATCH.with_borrow_mut(|near| {
            self.far.k_nearest(x, FAR_NEIGHBOURS, near);
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

    /// Orthogonal projection onto the surface: `x ← x − f(x) n(x)` until
    /// `|f| < tolerance` or [`MAX_PROJECTION_ITERATIONS`].
    pub fn project(&self, x: Vec3) -> Option<Projection> {
        let mut p = x;
        let mut s = self.sample(p)?;
        let mut iterations = 0;
        let mut converged = s.f.abs() < self.tolerance;
        while !converged && iterations < MAX_PROJECTION_ITERATIONS {
            p -= s.f * s.normal;
            s = self.sample(p)?;
            iterations += 1;
            converged = s.f.abs() < self.tolerance;
        }
        Some(Projection {
            point: p,
            normal: s.normal,
            signed_distance: (x - p).dot(s.normal),
            iterations,
            converged,
        })
    }

    /// Eq. (2): is `x` inside the surface? Also returns the projection.
    pub fn inside(&self, x: Vec3) -> Option<(bool, Projection)> {
        let p = self.project(x)?;
        Some((p.signed_distance < 0.0, p))
    }
}
