//! The `Dynamics` trait: what the contact pipeline needs from a simulation backend.
//!
//! The object owns its [`Phyxels`]; a backend keeps only its private state (stencils,
//! plastic strain, ...) and moves the phyxels one step at a time. External forces
//! (contact, user loads) arrive in `phyxels.force` and act during the next step.

pub mod gradient;
pub mod implicit;
pub mod kinematic;
pub mod stabilisation;

/// Renamed [`gradient`] (the MLS estimate of the displacement gradient); `mls` is the
/// backend ([`crate::backends::mls`]).
pub mod mls {
    pub use super::gradient::{GradientBasis, MAX_CONDITION};
    /// Moved to [`super::gradient::MlsStencil`].
    #[deprecated(note = "use phyxel::dynamics::gradient::MlsStencil")]
    pub type MlsStencil = super::gradient::MlsStencil;

    /// Moved to [`crate::math::linalg::cofactor`].
    #[deprecated(note = "use phyxel::math::linalg::cofactor")]
    pub fn cofactor(j: glam::Mat3) -> glam::Mat3 {
        crate::math::linalg::cofactor(j)
    }

    /// Moved to [`crate::math::linalg::pseudo_inverse`].
    #[deprecated(note = "use phyxel::math::linalg::pseudo_inverse")]
    pub fn pseudo_inverse(a: glam::DMat3) -> (glam::DMat3, bool) {
        crate::math::linalg::pseudo_inverse(a)
    }

    /// Moved to [`crate::math::linalg::sym_eigen`].
    #[deprecated(note = "use phyxel::math::linalg::sym_eigen")]
    pub fn sym_eigen(a: glam::DMat3) -> ([f64; 3], glam::DMat3) {
        crate::math::linalg::sym_eigen(a)
    }
}

/// Moved to [`crate::math::kernel`].
pub mod kernel {
    /// Moved to [`crate::math::kernel::poly6`].
    #[deprecated(note = "use phyxel::math::kernel::poly6")]
    pub fn poly6(r2: f32, h: f32) -> f32 {
        crate::math::kernel::poly6(r2, h)
    }

    /// Moved to [`crate::math::kernel::poly6_shape`].
    #[deprecated(note = "use phyxel::math::kernel::poly6_shape")]
    pub fn poly6_shape(r2: f32, h: f32) -> f32 {
        crate::math::kernel::poly6_shape(r2, h)
    }
}

use crate::columns::{LANES, Vec3s, load8, store8};
use crate::material::Material;
use crate::points::phyxels::Phyxels;
use glam::{Mat3, Vec3};
use wide::f32x8;

/// Everything a backend's step may read besides the phyxels. New fields may be added
/// without breaking implementors.
#[derive(Clone, Copy, Debug)]
#[non_exhaustive]
pub struct StepContext<'a> {
    /// Time step (s).
    pub dt: f32,
    /// Gravitational acceleration (m/s²).
    pub gravity: Vec3,
    /// The object's material.
    pub material: &'a Material,
}

impl<'a> StepContext<'a> {
    pub fn new(dt: f32, gravity: Vec3, material: &'a Material) -> Self {
        Self {
            dt,
            gravity,
            material,
        }
    }
}

/// Diagnostics a backend may report; `None` where it has no such notion.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Diagnostics {
    /// Potential (elastic) energy stored in the body (J).
    pub elastic_energy: Option<f64>,
    /// Largest Frobenius norm of the strain over the phyxels.
    pub max_strain: Option<f32>,
    /// Largest Frobenius norm of the plastic strain, where the backend keeps plastic
    /// state (`None`: it keeps none, as for elastic materials: no plasticity work).
    pub max_plastic_strain: Option<f32>,
    /// Phyxels whose neighbourhood does not span 3D (a rank-deficient or ill-conditioned
    /// moment matrix), where the backend fits one (`None`: it does not). Such a phyxel
    /// has no stiffness along the missing direction: a body one phyxel layer thick.
    pub flat_phyxels: Option<usize>,
    /// Work and convergence of an implicit backend's solves (`None`: it solves nothing).
    pub solver: Option<SolverStats>,
}

/// Work and convergence of an implicit backend's per-step solves, over the run so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SolverStats {
    /// Steps solved.
    pub steps: u64,
    /// Newton iterations and conjugate-gradient iterations, summed over the steps.
    pub newton_iterations: u64,
    pub cg_iterations: u64,
    /// Most CG iterations in one step.
    pub max_cg_per_step: u32,
    /// Final relative residual of the last step (`null` in JSON when it is not a
    /// number), and the largest finite one of any step.
    pub last_residual: f32,
    pub max_residual: f32,
    /// Steps whose residual was not a number (NaN or infinite): unconverged too.
    pub non_finite: u64,
    /// The tolerance on the relative residual.
    pub tolerance: f32,
    /// Steps accepted at the solver's floor (its f32 rounding) above the tolerance.
    pub at_floor: u64,
    /// Steps whose solve stopped above the tolerance without reaching the floor.
    pub unconverged: u64,
    /// Of those, the steps whose Newton iteration stagnated far above the rounding
    /// estimate (`crate::solver::ROUNDING_FACTOR`): a stalled solve, not the f32 floor.
    pub stalled: u64,
}

/// A dynamics backend for the phyxels of one object.
///
/// Implement it in your own crate to drive the contact pipeline with your own
/// physics; see docs/BACKENDS.md. The trait is object-safe, and `Any` so that a
/// caller can reach its own backend's state through [`crate::Object::dynamics_mut`].
pub trait Dynamics: std::any::Any + Send + Sync {
    /// Short backend name, as used in scenes (`"mls"`).
    fn name(&self) -> &str;

    /// Advances the phyxels by `ctx.dt` under gravity and `phyxels.force`, then clears
    /// `phyxels.force`. Must not move phyxels with `fixed` set.
    fn step(&mut self, phyxels: &mut Phyxels, ctx: &StepContext<'_>);

    /// Largest time step (s) for which the explicit step is stable: a number > 0,
    /// `f32::INFINITY` when nothing bounds it. Any other value (0, negative, NaN) is
    /// passed on by `World::stable_dt` with this object as the limiter (the caller who
    /// picks `World::dt` from it sees it there).
    fn stable_dt(&self, phyxels: &Phyxels, material: &Material) -> f32;

    /// The stable step (s) of this body's explicit counterpart (the same model stepped
    /// by symplectic Euler), for a backend with no bound of its own; `None` without one.
    /// `phyxel run` compares it with `dt` to say when stepping explicitly would be faster
    /// ([`crate::app::hint`]).
    fn explicit_dt(&self, _phyxels: &Phyxels, _material: &Material) -> Option<f32> {
        None
    }

    /// Displacement gradient `∇u` per phyxel (column b = ∂u/∂x_b), if the backend
    /// computes one. Without it, the core estimates one by MLS for surfel advection.
    fn displacement_gradient(&self) -> Option<&[Mat3]> {
        None
    }

    /// Energy and strain diagnostics of the current state.
    fn diagnostics(&self, _phyxels: &Phyxels, _material: &Material) -> Diagnostics {
        Diagnostics::default()
    }

    /// True if the object may break apart. Only then does the topology phase check the
    /// phyxels' connectivity after each step (no topology work for bodies that cannot
    /// fracture). Each piece gets its backend from [`Dynamics::fragment`].
    fn can_fracture(&self, _material: &Material) -> bool {
        false
    }

    /// The backend of a piece that broke off, built for the piece's `phyxels` (their
    /// rest state is the current one); `None` keeps the object whole. Default: `None`
    /// (the core does not know how to build a backend): a backend that may fracture
    /// overrides this, as the built-in ones do.
    fn fragment(&self, _phyxels: &Phyxels, _material: &Material) -> Option<Box<dyn Dynamics>> {
        None
    }

    /// True when the backend's plastic flow asks for a new rest configuration (Desbrun–Cani
    /// style time-varying connectivity). The object then replaces the rest positions of
    /// its phyxels and surfels by the current ones, re-binds its surfels and calls
    /// [`Dynamics::rest_replaced`]. Default: never.
    fn wants_new_rest(&self) -> bool {
        false
    }

    /// Called after the object replaced `phyxels.rest` by the current positions: rebuild
    /// whatever depends on the rest state (stencil, plastic strain, and what
    /// [`Dynamics::stable_dt`] reads: the world then lowers its dt if the bound fell).
    /// Default: nothing.
    fn rest_replaced(&mut self, _phyxels: &Phyxels, _material: &Material) {}

    /// True for backends that never move their phyxels (ground planes, fixed obstacles):
    /// the pipeline skips their step and advection.
    fn is_static(&self) -> bool {
        false
    }

    /// True for backends whose motion is prescribed, not integrated (a tool moved by the
    /// caller, a static object): the forces it receives move nothing, so its contacts
    /// impose no stability bound on it. Default: [`Dynamics::is_static`].
    fn is_prescribed(&self) -> bool {
        self.is_static()
    }

    /// The operators of a backward-Euler step, for a backend that joins the implicit
    /// solve ([`crate::solver`]): the world then steps it there instead of by
    /// [`Dynamics::step`], together with the implicit bodies it touches, and the contact
    /// springs between them (and against static objects) join the solve, so no contact
    /// stability bound applies to it. `None` (the default): explicit contact forces. The
    /// one place a backend says whether it joins ([`crate::Object::is_implicit`] reads
    /// it).
    fn implicit(&mut self) -> Option<&mut dyn implicit::Implicit> {
        None
    }

    /// Whether [`Dynamics::implicit`] returns `Some`; the engine no longer reads it.
    #[deprecated(note = "Dynamics::implicit is the one method: Object::is_implicit reads it")]
    fn is_implicit(&self) -> bool {
        false
    }
}

/// A body that does not move: ground planes and fixed obstacles.
#[derive(Clone, Copy, Debug, Default)]
pub struct StaticDynamics;

impl Dynamics for StaticDynamics {
    fn name(&self) -> &str {
        "static"
    }

    fn step(&mut self, phyxels: &mut Phyxels, _ctx: &StepContext<'_>) {
        phyxels.force.fill_zero();
    }

    fn stable_dt(&self, _phyxels: &Phyxels, _material: &Material) -> f32 {
        f32::INFINITY
    }

    fn is_static(&self) -> bool {
        true
    }
}

/// Largest stable step (s) of symplectic Euler for an oscillator of angular frequency
/// `omega` (1/s) with damping ratio `zeta`: `2/ω · (√(1 + ζ²) − ζ)` (2/ω undamped; a
/// dashpot integrated explicitly lowers it). Backends scale it by their own margin.
///
/// Evaluated as `2/ω / (√(1 + ζ²) + ζ)`, the same value without the cancellation of
/// the difference, which in f32 is 0 from ζ ≈ 4000 on (heavy damping then gave a zero
/// bound) and loses digits well before.
pub fn damped_euler_limit(omega: f32, zeta: f32) -> f32 {
    2.0 / omega / ((1.0 + zeta * zeta).sqrt() + zeta)
}

/// Symplectic (semi-implicit) Euler over SoA columns:
/// `v ← v + dt (f_int + f_ext)/m + dt g`, `x ← x + dt v`; fixed phyxels keep position and
/// zero velocity; `phyxels.force` is cleared. Shared by every backend.
///
/// The position sum is compensated (Kahan): the rounding error of `x + dt v` is kept in
/// `phyxels.pos_carry` and added to the next step's increment, so motions far below a
/// position's f32 resolution add up (a steel ball at y = 3 m falling at 0.1 m/s moved
/// 7·10⁻⁸ m per stable step, under half the 2.4·10⁻⁷ m ulp: it stood still).
///
/// # Panics
///
/// If `internal` holds fewer points than `phyxels` (a backend's force buffer must
/// match its phyxels: `Vec3s::zeros(phyxels.len())`); the message gives both counts.
pub fn integrate_symplectic(phyxels: &mut Phyxels, internal: &Vec3s, ctx: &StepContext<'_>) {
    // Checked here rather than left to the lane loads: a force buffer built empty or for
    // another object failed with "range end index 8 out of range for slice of length 0".
    let padded = phyxels.mass.len();
    assert!(
        internal.len() >= phyxels.len()
            && [&internal.x, &internal.y, &internal.z]
                .iter()
                .all(|c| c.len() >= padded),
        "integrate_symplectic: the internal forces hold {} points, the phyxels {}: size \
         the backend's force column by its phyxels (Vec3s::zeros(phyxels.len()))",
        internal.len(),
        phyxels.len()
    );
    let dt = f32x8::splat(ctx.dt);
    let g = [ctx.gravity.x, ctx.gravity.y, ctx.gravity.z].map(f32x8::splat);
    let Phyxels {
        pos,
        vel,
        force,
        mass,
        fixed,
        pos_carry,
        ..
    } = phyxels;
    for at in (0..mass.len()).step_by(LANES) {
        let m = load8(mass, at);
        // Padding lanes have zero mass: keep them at zero instead of dividing by it.
        let inv_m = m.simd_gt(f32x8::ZERO).select(f32x8::ONE / m, f32x8::ZERO);
        let free = f32x8::from(std::array::from_fn::<f32, 8, _>(|l| {
            if fixed[at + l] == 0 && mass[at + l] > 0.0 {
                1.0
            } else {
                0.0
            }
        }));
        let cols = [
            (
                &mut pos.x,
                &mut vel.x,
                &mut force.x,
                &internal.x,
                &mut pos_carry.x,
                g[0],
            ),
            (
                &mut pos.y,
                &mut vel.y,
                &mut force.y,
                &internal.y,
                &mut pos_carry.y,
                g[1],
            ),
            (
                &mut pos.z,
                &mut vel.z,
                &mut force.z,
                &internal.z,
                &mut pos_carry.z,
                g[2],
            ),
        ];
        for (x, v, f, fi, c, g) in cols {
            let f_tot = load8(f, at) + load8(fi, at);
            let v_new = (load8(v, at) + dt * (f_tot * inv_m + g)) * free;
            store8(v, at, v_new);
            let (x_old, step) = (load8(x, at), dt * v_new + load8(c, at));
            let x_new = x_old + step;
            // What the sum rounded away (exact in f32 for |step| ≤ |x_old|, and 0 for
            // a fixed phyxel, whose step is 0).
            store8(c, at, step - (x_new - x_old));
            store8(x, at, x_new);
            f[at..at + LANES].fill(0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::damped_euler_limit;

    /// The limit against the difference form evaluated in f64 (exact to ~ζ²·10⁻¹⁶
    /// relative, so up to ζ = 10⁴) and, beyond, its series `1/(2ζ) − 1/(8ζ³)`: within
    /// 10⁻⁶ relative (a few f32 ulps) for ζ from 0 to 10⁸, positive throughout. The
    /// f32 difference form failed this from ζ ≈ 8 on and gave 0 from ζ ≈ 4000.
    #[test]
    fn damped_limit_is_accurate_for_heavy_damping() {
        let omega = 3.0e4f32;
        let mut zeta = 0.0f64;
        while zeta <= 1.0e8 {
            let s = if zeta <= 1.0e4 {
                (1.0 + zeta * zeta).sqrt() - zeta
            } else {
                1.0 / (2.0 * zeta) - 1.0 / (8.0 * zeta.powi(3))
            };
            let reference = 2.0 / omega as f64 * s;
            let got = damped_euler_limit(omega, zeta as f32) as f64;
            let rel = (got - reference).abs() / reference;
            assert!(
                got > 0.0 && rel < 1.0e-6,
                "ζ = {zeta}: {got} against {reference} (relative error {rel:e})"
            );
            zeta = if zeta == 0.0 { 1.0e-3 } else { zeta * 1.7 };
        }
    }
}
