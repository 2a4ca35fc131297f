//! Backward Euler for implicit backends, with the contact springs between them in the
//! same solve.
//!
//! An implicit backend (such as `mls-implicit`) gives the operators of its step through
//! [`Implicit`]: the residual of backward Euler at trial velocities, its tangent
//! `M + c K` applied to a vector, a preconditioner, and the commit. [`solve`] runs
//! Newton's method with preconditioned conjugate gradients over a group of such bodies at
//! once (an *island*), and adds to the system the linearised penalty springs and
//! dashpots of the contact surfels between them, or between one of them and a static
//! object, with their friction ([`ContactSpring`]). A stiff contact
//! then no longer limits dt, and the springs' forces on the two sides are equal and
//! opposite at every iterate, so the island's momentum changes only by the external
//! impulse and the solver's final residual.

mod contact;

pub use contact::{ContactSpring, ContactSprings, SpringSide};

use super::{SolverStats, StepContext};
use crate::material::Material;
use crate::points::phyxels::Phyxels;
use contact::{Active, Side, spread};
use glam::Vec3;

/// The operators of a backward-Euler step that [`solve`] drives. Each works on the
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

/// CG stops at this fraction of the Newton residual (inexact Newton: the outer loop
/// corrects the rest).
const CG_FORCING: f64 = 0.05;

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
    /// Accepted at the f32 floor ([`FLOOR_TOLERANCE`]) above the tolerance.
    pub at_floor: bool,
    /// Stopped above the tolerance without reaching the floor.
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
        self.unconverged += r.unconverged as u64;
    }
}

/// One body of an island.
pub struct Member<'a> {
    /// Its index in `World::objects` (what [`SpringSide::object`] names).
    pub object: usize,
    pub dynamics: &'a mut dyn Implicit,
    pub phyxels: &'a mut Phyxels,
    pub material: &'a Material,
}

/// Buffers of [`solve`], kept between steps (no allocation in the steady step).
#[derive(Clone, Debug, Default)]
pub struct SolveScratch {
    offset: Vec<usize>,
    v0: Vec<Vec3>,
    v: Vec<Vec3>,
    g: Vec<Vec3>,
    r: Vec<Vec3>,
    z: Vec<Vec3>,
    p: Vec<Vec3>,
    ap: Vec<Vec3>,
    delta: Vec<Vec3>,
    /// The island's springs and their state.
    springs: Vec<Active>,
}

/// Steps an island of implicit bodies by one backward-Euler step of `dt`, with the
/// `springs` whose sides are all members or static (others are skipped), by Newton's
/// method with preconditioned CG. Each member's backend gets the [`SolveReport`].
pub fn solve(
    members: &mut [Member<'_>],
    springs: &ContactSprings,
    dt: f32,
    gravity: Vec3,
    scratch: &mut SolveScratch,
) -> SolveReport {
    let settings = members
        .iter()
        .map(|m| m.dynamics.settings())
        .reduce(|a, s| SolveSettings {
            tolerance: a.tolerance.min(s.tolerance),
            max_newton: a.max_newton.max(s.max_newton),
            max_cg: a.max_cg.max(s.max_cg),
        })
        .unwrap_or_default();
    let s = scratch;
    s.offset.clear();
    let mut total = 0;
    for m in members.iter() {
        s.offset.push(total);
        total += m.phyxels.len();
    }
    s.offset.push(total);
    for col in [
        &mut s.v0,
        &mut s.v,
        &mut s.g,
        &mut s.r,
        &mut s.z,
        &mut s.p,
        &mut s.ap,
        &mut s.delta,
    ] {
        col.clear();
        col.resize(total, Vec3::ZERO);
    }
    let slot = |object: u32| members.iter().position(|m| m.object == object as usize);
    // The island's springs: side a a member, side b a member or static.
    s.springs.clear();
    for (k, sp) in springs.springs.iter().enumerate() {
        let Some(ma) = slot(sp.a.object) else {
            continue;
        };
        let mb = match sp.b {
            Some(b) => match slot(b.object) {
                Some(mb) => Some((mb, b)),
                None => continue,
            },
            None => None,
        };
        s.springs.push(Active::new(
            k as u32,
            side(&s.offset, ma, sp.a),
            mb.map(|(mb, b)| side(&s.offset, mb, b)),
        ));
    }
    let mut momentum = 0.0f64;
    for (k, m) in members.iter_mut().enumerate() {
        m.dynamics
            .begin(m.phyxels, &StepContext::new(dt, gravity, m.material));
        let at = s.offset[k];
        for j in 0..m.phyxels.len() {
            let v = m.phyxels.vel.get(j);
            s.v0[at + j] = v;
            s.v[at + j] = v;
            if m.phyxels.fixed[j] == 0 {
                momentum += (m.phyxels.mass[j] * v.length_squared()) as f64;
            }
        }
    }
    let momentum = momentum.sqrt();
    for e in s.springs.iter_mut() {
        let sp = &springs.springs[e.index as usize];
        e.approach0 = sp.normal.dot(e.relative(&s.v0, springs));
    }
    let (mut newton, mut cg, mut scale, mut floor) = (0u32, 0u32, 0.0f64, 0.0f64);
    let (mut previous, mut stagnated) = (f64::INFINITY, false);
    let mut rel;
    loop {
        // The residual: each member's, then the springs'.
        let mut external = 0.0f64;
        for (k, m) in members.iter_mut().enumerate() {
            let r = s.offset[k]..s.offset[k + 1];
            let ctx = StepContext::new(dt, gravity, m.material);
            external += m
                .dynamics
                .residual(m.phyxels, &ctx, &s.v[r.clone()], &mut s.g[r]);
        }
        for e in s.springs.iter_mut() {
            let sp = &springs.springs[e.index as usize];
            let f = e.force(sp, e.relative(&s.v, springs), dt, newton) * dt;
            spread(&mut s.g, springs, members, &e.a, -f);
            if let Some(b) = &e.b {
                spread(&mut s.g, springs, members, b, f);
            }
        }
        let mut norm = 0.0f64;
        for (k, m) in members.iter().enumerate() {
            let at = s.offset[k];
            for j in 0..m.phyxels.len() {
                if m.phyxels.fixed[j] == 0 {
                    norm += s.g[at + j].length_squared() as f64 / m.phyxels.mass[j] as f64;
                }
            }
        }
        let norm = norm.sqrt();
        if newton == 0 {
            // Relative to the step's momentum change, its impulses or a share of its
            // momentum, whichever is largest: near equilibrium the first residual is
            // small, but the forces' rounding is not.
            let impulse = dt as f64 * external.sqrt();
            scale = norm.max(MOMENTUM_SHARE * momentum).max(impulse).max(1e-30);
            floor = (FLOOR_TOLERANCE * scale).max(MOMENTUM_FLOOR * momentum);
        }
        rel = norm / scale;
        if rel <= settings.tolerance as f64 || newton >= settings.max_newton || !rel.is_finite() {
            break;
        }
        // No longer halving: the forces' f32 rounding is reached (see FLOOR_TOLERANCE).
        if rel > 0.5 * previous && norm <= floor {
            stagnated = true;
            break;
        }
        previous = rel;
        for m in members.iter_mut() {
            m.dynamics
                .linearise(m.phyxels, &StepContext::new(dt, gravity, m.material));
        }
        cg += solve_cg(members, springs, s, settings.max_cg, dt, gravity);
        for (v, d) in s.v.iter_mut().zip(&s.delta) {
            *v += *d;
        }
        newton += 1;
    }
    for (k, m) in members.iter_mut().enumerate() {
        let r = s.offset[k]..s.offset[k + 1];
        let ctx = StepContext::new(dt, gravity, m.material);
        m.dynamics.commit(m.phyxels, &ctx, &s.v[r]);
    }
    let tolerance = settings.tolerance as f64;
    let converged = rel <= tolerance || stagnated;
    let report = SolveReport {
        newton_iterations: newton,
        cg_iterations: cg,
        residual: rel as f32,
        tolerance: settings.tolerance,
        at_floor: stagnated && converged && rel > tolerance,
        unconverged: !converged,
        springs: s.springs.len() as u32,
    };
    for m in members.iter_mut() {
        m.dynamics.record(&report);
    }
    report
}

fn side(offset: &[usize], member: usize, spring: SpringSide) -> Side {
    Side {
        offset: offset[member],
        member,
        spring,
    }
}

/// Solves `A δ = −g` over the island by preconditioned CG from δ = 0, to [`CG_FORCING`]
/// of `‖g‖`; returns the iterations. `A` is the members' tangents plus the pushing
/// springs' rows (normal spring, dashpot and friction); the preconditioner is the members' own
/// (block diagonal). Stops early on a direction of non-positive curvature (an
/// indefinite tangent: a buckling body), keeping the last iterate.
fn solve_cg(
    members: &mut [Member<'_>],
    springs: &ContactSprings,
    s: &mut SolveScratch,
    max_cg: u32,
    dt: f32,
    gravity: Vec3,
) -> u32 {
    let dot = |a: &[Vec3], b: &[Vec3]| a.iter().zip(b).map(|(x, y)| x.dot(*y) as f64).sum::<f64>();
    for j in 0..s.v.len() {
        s.delta[j] = Vec3::ZERO;
        s.r[j] = -s.g[j];
    }
    let r0 = dot(&s.r, &s.r).sqrt();
    if r0 == 0.0 {
        return 0;
    }
    let precondition = |members: &mut [Member<'_>], s: &mut SolveScratch| {
        for (k, m) in members.iter_mut().enumerate() {
            let r = s.offset[k]..s.offset[k + 1];
            m.dynamics
                .precondition(m.phyxels, &s.r[r.clone()], &mut s.z[r]);
        }
    };
    let apply = |members: &mut [Member<'_>], s: &mut SolveScratch| {
        for (k, m) in members.iter_mut().enumerate() {
            let r = s.offset[k]..s.offset[k + 1];
            let ctx = StepContext::new(dt, gravity, m.material);
            m.dynamics
                .apply(m.phyxels, &ctx, &s.p[r.clone()], &mut s.ap[r]);
        }
        for e in s.springs.iter().filter(|e| e.pushing) {
            let sp = &springs.springs[e.index as usize];
            let f = e.tangent(sp, e.relative(&s.p, springs), dt);
            spread(&mut s.ap, springs, members, &e.a, f);
            if let Some(b) = &e.b {
                spread(&mut s.ap, springs, members, b, -f);
            }
        }
    };
    precondition(members, s);
    s.p.copy_from_slice(&s.z);
    let mut rz = dot(&s.r, &s.z);
    let mut it = 0;
    while it < max_cg {
        it += 1;
        apply(members, s);
        let pap = dot(&s.p, &s.ap);
        if pap.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            if it == 1 {
                // The preconditioned direction itself: better than nothing.
                s.delta.copy_from_slice(&s.p);
            }
            break;
        }
        let alpha = (rz / pap) as f32;
        for j in 0..s.v.len() {
            s.delta[j] += s.p[j] * alpha;
            s.r[j] -= s.ap[j] * alpha;
        }
        if dot(&s.r, &s.r).sqrt() <= CG_FORCING * r0 {
            break;
        }
        precondition(members, s);
        let rz_new = dot(&s.r, &s.z);
        let beta = (rz_new / rz) as f32;
        rz = rz_new;
        for j in 0..s.v.len() {
            s.p[j] = s.z[j] + s.p[j] * beta;
        }
    }
    it
}
