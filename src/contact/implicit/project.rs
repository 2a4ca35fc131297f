//! Orthogonal projection onto the implicit surface (secant steps, halved when they leave
//! the kernels' reach), and the inside test built on it.

use super::*;

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
/// the floor; in a probe one epsilon let all converge, two leave a margin:
/// `tests/detect.rs`).
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
    /// [`ImplicitSurface::sample_near`] at `point` (the projection's last sample; `None`
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
pub(super) fn projection_step(s: &SurfaceSample, last: Option<(f32, SurfaceSample)>) -> f32 {
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

impl ImplicitSurface<'_> {
    /// Orthogonal projection onto the surface: `x ← x − t n(x)` until `|f| < tolerance`
    /// ([`PROJECTION_TOLERANCE`] σ, at least [`PROJECTION_ROUNDOFF_EPS`] epsilons of
    /// `x`'s largest coordinate) or [`MAX_PROJECTION_ITERATIONS`], with `t = f(x)` on the
    /// first step and the secant step of [`PROJECTION_SLOPE_RANGE`] after a step between
    /// two kernel samples (far-field samples take the plain step); a step from within
    /// the kernels' reach that leaves it is halved, up to [`MAX_STEP_HALVINGS`] times.
    pub fn project(&self, x: Vec3) -> Option<Projection> {
        self.project_given(x, self.sample_near(x))
    }

    /// [`ImplicitSurface::project`] where [`ImplicitSurface::sample_near`] at `x` gave
    /// `near`: the same result without sampling `x` again.
    pub fn project_given(&self, x: Vec3, near: Option<SurfaceSample>) -> Option<Projection> {
        self.project_hinted(x, near, &mut FarHint::default())
    }

    /// [`ImplicitSurface::project_given`] whose far-field sample at `x` (if `x` is far
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

    /// [`ImplicitSurface::inside`] given [`ImplicitSurface::sample_near`] at `x`.
    pub fn inside_given(&self, x: Vec3, near: Option<SurfaceSample>) -> Option<(bool, Projection)> {
        self.inside_hinted(x, near, &mut FarHint::default())
    }

    /// [`ImplicitSurface::inside_given`] with the far-field search of
    /// [`ImplicitSurface::project_hinted`].
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
