//! Backward Euler for implicit backends, with the contact springs between them in the
//! same solve.
//!
//! An implicit backend (such as `mls-implicit`) gives the operators of its step through
//! [`Implicit`]: the residual of backward Euler at trial velocities, its tangent
//! `M + c K` applied to a vector, a preconditioner, and the commit. [`solve`] runs
//! Newton's method with preconditioned conjugate gradients over a group of such bodies at
//! once (an *island*), and adds to the system the linearised penalty springs and
//! dashpots of the contact surfels between them, or between one of them and a static
//! object ([`ContactSpring`]). A stiff contact then no longer limits dt, and the springs'
//! forces on the two sides are equal and opposite at every iterate, so the island's
//! momentum changes only by the external impulse and the solver's final residual.
//!
//! The contact force of each contact surfel is computed by the contact pipeline at the
//! end of the previous step (positions `xₙ`) and arrives in `phyxels.force`; the spring
//! adds its change over the step, `ΔF = −k (dt v_rel) − c (v_rel − v_rel,ₙ)` along the
//! contact normal (`v_rel`: the velocity of side a relative to side b at the surfel),
//! clamped so that the total normal force only pushes. This is the linearly implicit
//! contact of Baraff and Witkin (1998): one Newton step of the contact force per time
//! step, exact for a contact that keeps its surfels and normal over the step.

use super::{SolverStats, StepContext};
use crate::body::material::Material;
use crate::body::phyxels::Phyxels;
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
/// scale: the largest of its first residual, its momentum `‖vₙ‖_M` and its external
/// impulse. The forces are f32: the residual of a stiff body cannot go much below a few
/// percent of its weight's impulse ([`FLOOR_TOLERANCE`]).
pub const NEWTON_TOLERANCE: f32 = 1e-4;

/// A step whose Newton iteration stagnates (the residual no longer halves) below this
/// fraction of its scale is accepted: it has reached the f32 rounding of the forces.
/// A displacement of 1 cm is resolved to 1e-9 m, which a stiff body's stiffness (2.5e6
/// N/m per phyxel for the E = 1e8 Pa cantilever) turns into force noise of a few percent
/// of a phyxel's weight; the cantilever's steps stagnate at 0.2–1.5% of their impulses.
pub const FLOOR_TOLERANCE: f64 = 0.05;

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
        self.max_residual = self.max_residual.max(r.residual);
        self.last_residual = r.residual;
        self.tolerance = r.tolerance;
        self.at_floor += r.at_floor as u64;
        self.unconverged += r.unconverged as u64;
    }
}

/// One side of a [`ContactSpring`]: an object and the phyxels the contact surfel's
/// motion is read from and its force spread to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringSide {
    /// The object (index into `World::objects`).
    pub object: u32,
    /// Its phyxels and their normalised weights: `ContactSprings::weights[start..end]`.
    pub start: u32,
    pub end: u32,
}

/// The linearised penalty spring and dashpot of one contact surfel (Keiser et al. 2004,
/// eqs. 3–7, differentiated along the contact normal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactSpring {
    /// Unit normal along which the force on side a pushes it out of side b.
    pub normal: Vec3,
    /// dF/dδ, `½ k A` (N/m): the force on a grows by this per metre of approach.
    pub stiffness: f32,
    /// dF/dv, `c A` (N·s/m), per m/s of approach speed.
    pub damping: f32,
    /// The normal force on a at the start of the step (N): the spring's change may lower
    /// the total to zero, not below. Negative for a kept spring (`applied` false): its
    /// side has lifted off, by `−force / stiffness` metres.
    pub force: f32,
    /// `force` is in the phyxels' external forces already (the contact pipeline spread
    /// it): the solve adds the change only. Otherwise it adds `max(0, force + change)`.
    pub applied: bool,
    pub a: SpringSide,
    /// `None` when the other side is a static object (it does not move).
    pub b: Option<SpringSide>,
}

/// The contact springs of the last step, over the whole world.
#[derive(Clone, Debug, Default)]
pub struct ContactSprings {
    pub springs: Vec<ContactSpring>,
    /// (phyxel, normalised weight) lists of the springs' sides.
    pub weights: Vec<(u32, f32)>,
}

impl ContactSprings {
    pub fn clear(&mut self) {
        self.springs.clear();
        self.weights.clear();
    }

    /// A side's (phyxel, normalised weight) list.
    pub fn weights_of(&self, side: &SpringSide) -> &[(u32, f32)] {
        &self.weights[side.start as usize..side.end as usize]
    }

    /// The weighted mean of `value(phyxel)` over a side's phyxels: the motion of its
    /// contact surfel.
    pub fn mean(&self, side: &SpringSide, value: impl Fn(usize) -> Vec3) -> Vec3 {
        self.weights_of(side)
            .iter()
            .map(|&(j, w)| value(j as usize) * w)
            .sum()
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
    /// Per spring of the island: its index, approach speed at `vₙ`, and whether it
    /// pushes at the current iterate.
    springs: Vec<(u32, f32, bool)>,
    /// The island's springs' sides.
    sides: Vec<(Side, Option<Side>)>,
}

/// Where a spring side's dofs lie in the island's vectors.
#[derive(Clone, Copy, Debug)]
struct Side {
    offset: usize,
    member: usize,
    spring: SpringSide,
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
    s.sides.clear();
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
        s.springs.push((k as u32, 0.0, true));
        s.sides.push((
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
    for (e, (a, b)) in s.springs.iter_mut().zip(&s.sides) {
        let sp = &springs.springs[e.0 as usize];
        e.1 = approach(&s.v0, springs, sp.normal, a, b.as_ref());
    }
    let (mut newton, mut cg, mut scale) = (0u32, 0u32, 0.0f64);
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
        for (e, (a, b)) in s.springs.iter_mut().zip(&s.sides) {
            let sp = &springs.springs[e.0 as usize];
            let now = approach(&s.v, springs, sp.normal, a, b.as_ref());
            let change = -sp.stiffness * dt * now - sp.damping * (now - e.1);
            // Push only: the spring may take the force to zero, not pull.
            e.2 = change > -sp.force;
            let change = if sp.applied {
                change.max(-sp.force)
            } else {
                (sp.force + change).max(0.0)
            };
            let f = sp.normal * (change * dt);
            spread(&mut s.g, springs, members, a, -f);
            if let Some(b) = b {
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
            // Relative to the step's momentum change, its momentum or its impulses,
            // whichever is largest: near equilibrium the first residual is small, but
            // the forces' rounding is not.
            let impulse = dt as f64 * external.sqrt();
            scale = norm.max(momentum).max(impulse).max(1e-30);
        }
        rel = norm / scale;
        if rel <= settings.tolerance as f64 || newton >= settings.max_newton || !rel.is_finite() {
            break;
        }
        // No longer halving: the forces' f32 rounding is reached (see FLOOR_TOLERANCE).
        if rel > 0.5 * previous && rel <= FLOOR_TOLERANCE {
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
    let converged = rel <= tolerance || (stagnated && rel <= FLOOR_TOLERANCE);
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

/// Approach speed of side a relative to side b along `n` (m/s) for the island's vector
/// `x`: positive when a moves away from b (`n` pushes a out), so the spring's change is
/// `−k dt · approach`.
fn approach(x: &[Vec3], springs: &ContactSprings, n: Vec3, a: &Side, b: Option<&Side>) -> f32 {
    let mean = |s: &Side| springs.mean(&s.spring, |j| x[s.offset + j]);
    n.dot(mean(a) - b.map_or(Vec3::ZERO, mean))
}

/// Adds `f` spread by the side's weights to `out` (fixed phyxels take nothing).
fn spread(out: &mut [Vec3], springs: &ContactSprings, members: &[Member<'_>], s: &Side, f: Vec3) {
    let fixed = &members[s.member].phyxels.fixed;
    for &(j, w) in springs.weights_of(&s.spring) {
        if fixed[j as usize] == 0 {
            out[s.offset + j as usize] += f * w;
        }
    }
}

/// Solves `A δ = −g` over the island by preconditioned CG from δ = 0, to [`CG_FORCING`]
/// of `‖g‖`; returns the iterations. `A` is the members' tangents plus the active
/// springs' `(k dt² + c dt) w nnᵀ wᵀ`; the preconditioner is the members' own
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
        for (e, (a, b)) in s.springs.iter().zip(&s.sides) {
            if !e.2 {
                continue;
            }
            let sp = &springs.springs[e.0 as usize];
            let coef = sp.stiffness * dt * dt + sp.damping * dt;
            let t = coef * approach(&s.p, springs, sp.normal, a, b.as_ref());
            let f = sp.normal * t;
            spread(&mut s.ap, springs, members, a, f);
            if let Some(b) = b {
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
