//! What a backend gives to join the implicit solve: the operators of its backward-Euler
//! step ([`Implicit`]: the residual at trial velocities, its tangent `M + c K` applied to
//! a vector, a preconditioner, the commit), and the settings and outcome of a solve.
//! The solve itself — islands, contact springs, Newton–CG, the preconditioner's
//! factor, the default dt — is [`crate::solver`].

use super::{SolverStats, StepContext};
use crate::points::phyxels::Phyxels;
use glam::{Mat3, Vec3};

/// The operators of a backward-Euler step that [`crate::solver::solve`] drives. Each works on the
/// body's own phyxels, with vectors of one entry per phyxel (no padding).
pub trait Implicit: Send {
    /// Starts a step: keeps `xₙ`, `vₙ` (= `phyxels.vel`) and the external forces
    /// `phyxels.force`, and prepares the preconditioner for `ctx.dt`.
    fn begin(&mut self, phyxels: &Phyxels, ctx: &StepContext<'_>);

    /// The residual at trial velocities `v` (positions `xₙ + dt v`):
    /// `g = M (v − vₙ) − dt (f(xₙ + dt v, v) + f_ext + M g)`, zero at fixed phyxels.
    /// Returns `Σ |f_ext + m g|² / m` over the free phyxels (the scale of the step's
    /// external impulse). May write the trial state into `phyxels`.
    fn residual(
        &mut self,
        phyxels: &mut Phyxels,
        ctx: &StepContext<'_>,
        v: &[Vec3],
        g: &mut [Vec3],
    ) -> f64;

    /// Linearises the forces at the state of the last [`Implicit::residual`].
    fn linearise(&mut self, phyxels: &Phyxels, ctx: &StepContext<'_>);

    /// `ap = (M + c K) p` with `K = −∂f/∂x` at the last linearisation and
    /// `c = dt² + dt τ` (τ: the backend's viscous time, 0 without); zero at fixed
    /// phyxels.
    fn apply(&mut self, phyxels: &Phyxels, ctx: &StepContext<'_>, p: &[Vec3], ap: &mut [Vec3]);

    /// `z ≈ (M + c K)⁻¹ r`, symmetric positive definite; zero at fixed phyxels.
    fn precondition(&mut self, phyxels: &Phyxels, r: &[Vec3], z: &mut [Vec3]);

    /// Whether [`Implicit::precondition`] is the mass alone because the body's full
    /// preconditioner has not been built yet. The solve asks for it
    /// ([`Implicit::prepare_preconditioner`]) only when a CG solve on the mass alone
    /// has not converged within [`crate::solver::DEFERRED_CG`] iterations: a body in
    /// free flight, whose step the mass alone solves, never pays for it. The default:
    /// never deferred.
    fn preconditioner_deferred(&self) -> bool {
        false
    }

    /// Builds the full preconditioner for `ctx.dt` now (see
    /// [`Implicit::preconditioner_deferred`]).
    fn prepare_preconditioner(&mut self, _phyxels: &Phyxels, _ctx: &StepContext<'_>) {}

    /// The contact springs' share of this step's system, lumped to one symmetric
    /// positive semi-definite 3×3 block per phyxel (world frame; see
    /// [`crate::solver::active`]), for [`Implicit::precondition`] to add: a stiff or
    /// sticking contact is then no harder for CG than the body alone. Empty: no
    /// contact. The default ignores it.
    fn contact_blocks(&mut self, _phyxels: &Phyxels, _blocks: &[Mat3]) {}

    /// The size of the f32 rounding (m) of the displacement each phyxel's forces are
    /// computed from, per coordinate, at the last [`Implicit::residual`]: through the
    /// stiffness it sets the residual's floor, below which Newton cannot go (the solver
    /// tells a step stalled above it from one at it). The default is that of the
    /// positions themselves, `|x| · 2⁻²⁴`.
    fn displacement_rounding(&self, phyxels: &Phyxels, out: &mut [Vec3]) {
        for (j, r) in out.iter_mut().enumerate() {
            *r = phyxels.pos.get(j).abs() * F32_UNIT_ROUNDOFF;
        }
    }

    /// Ends the step at velocities `v` (those of the last residual): positions
    /// `xₙ + dt v`, velocities `v`, `phyxels.force` cleared, fixed phyxels held.
    fn commit(&mut self, phyxels: &mut Phyxels, ctx: &StepContext<'_>, v: &[Vec3]);

    /// The step's outcome, for the backend's [`SolverStats`].
    fn record(&mut self, report: &SolveReport);

    /// Tolerance and iteration caps of this body's solves.
    fn settings(&self) -> SolveSettings {
        SolveSettings::default()
    }
}

/// f32's unit roundoff, `2⁻²⁴`: a value is rounded to within this fraction of itself.
pub const F32_UNIT_ROUNDOFF: f32 = f32::EPSILON / 2.0;

/// Newton stops when the residual's `M⁻¹` norm falls to this fraction of the step's
/// scale: the largest of its first residual, its external impulse and
/// [`MOMENTUM_SHARE`] of its momentum `‖vₙ‖_M`. The forces are f32: the residual of a
/// stiff body cannot go much below a few percent of its weight's impulse
/// ([`FLOOR_TOLERANCE`]).
pub const NEWTON_TOLERANCE: f32 = 1e-4;

/// The share of a body's momentum in the scale of its residual, so that a moving body's
/// steps are solved about as finely as a resting one's: with the whole momentum, a
/// block sliding at 0.3 m/s (momentum 150 times its step's impulse at dt = 0.2 ms) was
/// allowed a residual of 1.5% of each step's impulse, and the `incline-slide`
/// acceleration came out 0.2% low (with 1%, 2.5e-4 low at dt = 5e-5 s). The f32 floor
/// is judged against the whole momentum ([`FLOOR_TOLERANCE`]).
pub const MOMENTUM_SHARE: f64 = 1e-3;

/// A step whose Newton iteration stagnates (the residual no longer halves) below this
/// fraction of its scale is accepted: it has reached the f32 rounding of the forces.
/// A moving body's floor is its momentum's instead ([`MOMENTUM_FLOOR`]).
/// A displacement of 1 cm is resolved to 1e-9 m, which a stiff body's stiffness (2.5e6
/// N/m per phyxel for the E = 1e8 Pa cantilever) turns into force noise of a few percent
/// of a phyxel's weight; the cantilever's steps stagnate at 0.2–1.5% of their impulses.
pub const FLOOR_TOLERANCE: f64 = 0.05;

/// A stagnated step of a moving body is also accepted below this fraction of its whole
/// momentum `‖vₙ‖_M`: a body moving freely rounds its forces at about 1e-3 of its
/// momentum per step (five times that is allowed). [`FLOOR_TOLERANCE`] of the
/// momentum would accept steps 50 times above the tolerance as at the floor (two
/// spheres closing at 2 m/s at dt = 0.05 s stagnate at a residual of 0.69).
pub const MOMENTUM_FLOOR: f64 = 5e-3;

/// Newton iterations per step at most.
pub const MAX_NEWTON: u32 = 10;

/// CG iterations per Newton step at most.
pub const MAX_CG: u32 = 200;

/// Tolerance and iteration caps of a solve; an island takes the strictest of its
/// members'.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveSettings {
    /// Newton tolerance on the relative residual.
    pub tolerance: f32,
    /// Newton iterations per step at most.
    pub max_newton: u32,
    /// CG iterations per Newton step at most.
    pub max_cg: u32,
}

impl Default for SolveSettings {
    fn default() -> Self {
        Self {
            tolerance: NEWTON_TOLERANCE,
            max_newton: MAX_NEWTON,
            max_cg: MAX_CG,
        }
    }
}

/// The outcome of one step's solve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveReport {
    pub newton_iterations: u32,
    pub cg_iterations: u32,
    /// Final relative residual.
    pub residual: f32,
    pub tolerance: f32,
    /// The residual's f32 rounding estimated from the backend's stiffness, relative as
    /// `residual` (0 when not asked: only a step that stagnated above the tolerance is).
    pub rounding: f32,
    /// Stagnated above the tolerance, within [`ROUNDING_FACTOR`](crate::solver::ROUNDING_FACTOR) of `rounding`: converged
    /// as far as f32 forces allow.
    pub at_floor: bool,
    /// Stagnated above the tolerance, more than [`ROUNDING_FACTOR`](crate::solver::ROUNDING_FACTOR) times `rounding`:
    /// the solve stalled (counted in `unconverged` too).
    pub stalled: bool,
    /// Stopped above the tolerance, not at the floor.
    pub unconverged: bool,
    /// Contact springs in the solve.
    pub springs: u32,
}

impl SolverStats {
    /// Adds one step's report.
    pub fn record(&mut self, r: &SolveReport) {
        self.steps += 1;
        self.newton_iterations += r.newton_iterations as u64;
        self.cg_iterations += r.cg_iterations as u64;
        self.max_cg_per_step = self.max_cg_per_step.max(r.cg_iterations);
        // A NaN residual is counted, not lost (`f32::max` passes NaN by).
        if r.residual.is_finite() {
            self.max_residual = self.max_residual.max(r.residual);
        } else {
            self.non_finite += 1;
        }
        self.last_residual = r.residual;
        self.tolerance = r.tolerance;
        self.at_floor += r.at_floor as u64;
        self.stalled += r.stalled as u64;
        self.unconverged += r.unconverged as u64;
    }
}
