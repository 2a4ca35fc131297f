//! Newton's method with preconditioned conjugate gradients over an island: the
//! members' backward-Euler residuals and tangents ([`Implicit`]) plus the rows of the
//! contact springs between them ([`super::active`]).

use super::active::{Active, Side, lump};
use super::springs::{ContactSprings, SpringSide};
use super::transfer::{self, Transfer};
use crate::dynamics::StepContext;
use crate::dynamics::implicit::{
    FLOOR_TOLERANCE, Implicit, MOMENTUM_FLOOR, MOMENTUM_SHARE, SolveReport, SolveSettings,
};
use crate::material::Material;
use crate::points::phyxels::Phyxels;
use glam::{DVec3, Mat3, Vec3};
use rayon::prelude::*;
use wide::f32x8;

/// CG stops at this fraction of the Newton residual (inexact Newton: the outer loop
/// corrects the rest), or at a larger one near the tolerance ([`forcing`]).
const CG_FORCING: f64 = 0.05;

/// The largest forcing [`forcing`] gives.
const MAX_FORCING: f64 = 0.5;

/// The fraction of the Newton residual at which CG stops, for a relative residual `rel`
/// and the step's `tolerance`: [`CG_FORCING`], or, when the residual is already near the
/// tolerance, the fraction that brings it to half the tolerance if the step were linear
/// (at most [`MAX_FORCING`]). The last Newton step then solves only as accurately as
/// the tolerance asks, in the spirit of Eisenstat and Walker's forcing terms (1996).
fn forcing(rel: f64, tolerance: f64) -> f64 {
    (0.5 * tolerance / rel).clamp(CG_FORCING, MAX_FORCING)
}

/// CG iterations on the mass alone after which the members whose full preconditioner
/// is deferred ([`Implicit::preconditioner_deferred`]) build it and the solve starts
/// again: a body in free flight converges in one.
pub const DEFERRED_CG: u32 = 4;

/// A stagnated step is at the f32 floor when its residual is at most this multiple of
/// the rounding estimate: the island's tangent applied to the rounding of the
/// displacements its forces read ([`Implicit::displacement_rounding`]), a typical size
/// rather than a bound, to which the forces' own arithmetic adds. Elastic bodies
/// stagnate at 0.14–0.71 times the estimate (docs/BACKENDS.md, "Convergence").
pub const ROUNDING_FACTOR: f64 = 10.0;

/// Halvings of a Newton step that raised the residual, at most.
const MAX_HALVINGS: u32 = 4;

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
    /// The springs' rows lumped per phyxel ([`Implicit::contact_blocks`]).
    blocks: Vec<Mat3>,
    /// The island's springs and their state.
    springs: Vec<Active>,
    /// Each spring's force on side a in the current product (N, or N·s in the residual).
    spring_force: Vec<Vec3>,
    /// The springs' reading and spreading in lanes.
    transfer: Transfer,
    /// Per island row, the springs' spread forces before [`transfer::finish`].
    sums: Vec<f32x8>,
    /// The springs' sides by member.
    sides: MemberSides,
}

/// The springs' sides by member: `sides[start[k]..start[k + 1]]` are member k's, each
/// `2 × spring + (0 for side a, 1 for side b)`, in the springs' order.
#[derive(Clone, Debug, Default)]
struct MemberSides {
    sides: Vec<u32>,
    start: Vec<usize>,
}

impl MemberSides {
    /// Lists the sides of `springs` for `members` members.
    fn list(&mut self, members: usize, springs: &[Active]) {
        self.start.clear();
        self.start.resize(members + 1, 0);
        for e in springs {
            self.start[e.a.member + 1] += 1;
            if let Some(b) = &e.b {
                self.start[b.member + 1] += 1;
            }
        }
        for k in 0..members {
            self.start[k + 1] += self.start[k];
        }
        self.sides.clear();
        self.sides.resize(self.start[members], 0);
        // Each member's start serves as its cursor, and ends at the next member's start.
        for (i, e) in springs.iter().enumerate() {
            let mut put = |member: usize, code: u32| {
                self.sides[self.start[member]] = code;
                self.start[member] += 1;
            };
            put(e.a.member, 2 * i as u32);
            if let Some(b) = &e.b {
                put(b.member, 2 * i as u32 + 1);
            }
        }
        self.start.copy_within(0..members, 1);
        self.start[0] = 0;
    }

    /// Member k's sides.
    fn of(&self, k: usize) -> &[u32] {
        &self.sides[self.start[k]..self.start[k + 1]]
    }
}

impl SolveScratch {
    /// Forgets the last solve's springs: a body that does not solve this step (asleep,
    /// or now in another body's island) must not hand their reactions on again.
    pub fn forget_springs(&mut self) {
        self.springs.clear();
    }

    /// Each spring of the last solve, its index in the [`ContactSprings`] and its friction
    /// anchor's elongation at the last iterate (m).
    pub fn sticks(&self) -> impl Iterator<Item = (usize, Vec3)> + '_ {
        self.springs.iter().map(|e| (e.index as usize, e.stick))
    }

    /// The springs of the last solve whose side b was given (a tool), each with its
    /// index in the [`ContactSprings`] and its force on side b at the last iterate (N).
    pub fn given_reactions(&self) -> impl Iterator<Item = (usize, Vec3)> + '_ {
        self.springs
            .iter()
            .filter(|e| e.b.is_none())
            .map(|e| (e.index as usize, -e.last_force))
    }
}

/// Steps an island of implicit bodies by one backward-Euler step of `dt`, with the
/// `springs` of its members against members, static objects and tools (side b at its
/// [`ContactSpring::given`](super::ContactSpring::given) velocity), by Newton's
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
    s.transfer.begin(members.iter().map(|m| &*m.phyxels));
    s.sums.clear();
    s.sums.resize(total, f32x8::ZERO);
    let slot = |object: u32| members.iter().position(|m| m.object == object as usize);
    // The island's springs: side a a member, side b a member, static or a tool (a body
    // outside every island: its motion is given).
    s.springs.clear();
    for (k, sp) in springs.springs.iter().enumerate() {
        let Some(ma) = slot(sp.a.object) else {
            continue;
        };
        let (mb, given) = match sp.b {
            None => (None, Vec3::ZERO),
            Some(b) => match (slot(b.object), sp.given) {
                (Some(mb), _) => (
                    Some(side(&s.offset, mb, b, &s.transfer, springs)),
                    Vec3::ZERO,
                ),
                (None, Some(given)) => (None, given),
                // A body asleep since the springs were built: held where it is.
                (None, None) => (None, Vec3::ZERO),
            },
        };
        let a = side(&s.offset, ma, sp.a, &s.transfer, springs);
        s.springs.push(Active::new(k as u32, a, mb, given));
    }
    s.sides.list(members.len(), &s.springs);
    let mut momentum = 0.0f64;
    on_each_member(members, &s.offset, &|m| {
        m.dynamics
            .begin(m.phyxels, &StepContext::new(dt, gravity, m.material));
    });
    for (k, m) in members.iter_mut().enumerate() {
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
    s.transfer.load(&s.v0);
    for e in s.springs.iter_mut() {
        let sp = &springs.springs[e.index as usize];
        e.approach0 = sp.normal.dot(e.relative(&s.transfer, springs));
    }
    let (mut newton, mut cg, mut scale, mut floor) = (0u32, 0u32, 0.0f64, 0.0f64);
    let (mut previous, mut stagnated, mut halvings) = (f64::INFINITY, false, 0);
    // The rounding estimate, relative to the scale ([`rounding_floor`]; negative: not
    // yet computed), and the springs' states at the last accepted iterate.
    let (mut rounding, mut previous_contact) = (-1.0f64, 0u64);
    let mut rel;
    loop {
        // The residual: the springs' forces, then each member's own with its springs'.
        s.transfer.load(&s.v);
        let transfer = &s.transfer;
        s.spring_force.resize(s.springs.len(), Vec3::ZERO);
        s.springs
            .par_iter_mut()
            .zip(s.spring_force.par_iter_mut())
            .with_min_len(SPRING_TASK)
            .for_each(|(e, f)| {
                let sp = &springs.springs[e.index as usize];
                *f = e.force(sp, e.relative(transfer, springs), dt, newton) * -dt;
            });
        let (spread, v, rows) = Spread::pass(springs, s, Target::Residual);
        let external = each_member(members, spread.offset, v, rows, &|at, m, v, (g, sums)| {
            let ctx = StepContext::new(dt, gravity, m.material);
            let external = m.dynamics.residual(m.phyxels, &ctx, v, g);
            spread.add(at, m, sums, g);
            external
        });
        let norm = inverse_mass_norm(members, &s.offset, |i, _| s.g[i]);
        if newton == 0 {
            // Relative to the step's momentum change, its impulses or a share of its
            // momentum, whichever is largest: near equilibrium the first residual is
            // small, but the forces' rounding is not.
            let impulse = dt as f64 * external.sqrt();
            scale = norm.max(MOMENTUM_SHARE * momentum).max(impulse).max(1e-30);
            floor = (FLOOR_TOLERANCE * scale).max(MOMENTUM_FLOOR * momentum);
        }
        rel = norm / scale;
        if rel <= settings.tolerance as f64 {
            break;
        }
        // A Newton step that raised the residual of an island in contact (a spring that
        // stopped or started pushing, a slip that turned across it) is halved, back
        // towards the last iterate.
        if newton > 0
            && !s.springs.is_empty()
            && (rel > previous || rel.is_nan())
            && halvings < MAX_HALVINGS
        {
            halvings += 1;
            for (v, d) in s.v.iter_mut().zip(s.delta.iter_mut()) {
                *d *= 0.5;
                *v -= *d;
            }
            continue;
        }
        halvings = 0;
        if newton >= settings.max_newton || !rel.is_finite() {
            break;
        }
        // No longer halving: the forces' f32 rounding is reached (see FLOOR_TOLERANCE),
        // unless the residual is far above that rounding and the step moved the contact
        // onto another piece of its law (a spring started or stopped pushing, or
        // turned between sticking and sliding), from which Newton converges again.
        let contact = contact_state(&s.springs);
        if rel > 0.5 * previous && norm <= floor {
            if rounding < 0.0 {
                rounding = rounding_floor(members, springs, s, dt, gravity) / scale;
            }
            if rel <= ROUNDING_FACTOR * rounding || contact == previous_contact {
                stagnated = true;
                break;
            }
        }
        previous = rel;
        previous_contact = contact;
        if newton == 0 {
            contact_blocks(members, springs, s, dt);
        }
        on_each_member(members, &s.offset, &|m| {
            m.dynamics
                .linearise(m.phyxels, &StepContext::new(dt, gravity, m.material));
        });
        let forcing = forcing(rel, settings.tolerance as f64);
        cg += solve_cg(members, springs, s, settings.max_cg, forcing, dt, gravity);
        for (v, d) in s.v.iter_mut().zip(&s.delta) {
            *v += *d;
        }
        newton += 1;
    }
    remove_translation(members, s);
    each_member(
        members,
        &s.offset,
        &s.v,
        &mut [] as &mut [Vec3],
        &|_, m, v, _| {
            let ctx = StepContext::new(dt, gravity, m.material);
            m.dynamics.commit(m.phyxels, &ctx, v);
            0.0
        },
    );
    let tolerance = settings.tolerance as f64;
    // A stagnated step above the tolerance is at the floor only if the backend's
    // rounding explains its residual; otherwise it has stalled, and says so.
    let rounding = rounding.max(0.0);
    let at_floor = stagnated && rel > tolerance && rel <= ROUNDING_FACTOR * rounding;
    let stalled = stagnated && rel > tolerance && !at_floor;
    let report = SolveReport {
        newton_iterations: newton,
        cg_iterations: cg,
        residual: rel as f32,
        tolerance: settings.tolerance,
        rounding: rounding as f32,
        at_floor,
        stalled,
        unconverged: !(rel <= tolerance || at_floor),
        springs: s.springs.len() as u32,
    };
    for m in members.iter_mut() {
        m.dynamics.record(&report);
    }
    report
}

/// Rows of the island's vectors that [`each_member`] hands out member by member: one
/// vector, or two side by side.
trait Rows: Send + Sized {
    /// The first `at` rows and the rest (an empty vector stays empty).
    fn split(self, at: usize) -> (Self, Self);
}

impl<T: Send> Rows for &mut [T] {
    fn split(self, at: usize) -> (Self, Self) {
        let at = at.min(self.len());
        self.split_at_mut(at)
    }
}

impl<A: Rows, B: Rows> Rows for (A, B) {
    fn split(self, at: usize) -> (Self, Self) {
        let ((a0, a1), (b0, b1)) = (self.0.split(at), self.1.split(at));
        ((a0, b0), (a1, b1))
    }
}

/// Runs `f` on every member with its first row in the island's vectors and its rows of
/// `input` and `output` (either may be empty: then each member gets an empty slice), the
/// members split into halves of the rows by `rayon::join`, and sums what `f` returns in
/// that fixed tree: the same bits on any number of threads. An island's members are
/// independent between the springs' rows, so a heap of bodies preconditions, applies
/// and refactors in parallel.
fn each_member<T, O, F>(
    members: &mut [Member<'_>],
    offset: &[usize],
    input: &[T],
    output: O,
    f: &F,
) -> f64
where
    T: Sync,
    O: Rows,
    F: Fn(usize, &mut Member<'_>, &[T], O) -> f64 + Sync,
{
    match members.len() {
        0 => 0.0,
        1 => f(offset[0], &mut members[0], input, output),
        n => {
            // Halves of the rows rather than of the members: bodies differ in size.
            let half = (offset[0] + offset[n]) / 2;
            let mid = (1..n)
                .min_by_key(|&k| offset[k].abs_diff(half))
                .expect("two members or more");
            let cut = offset[mid] - offset[0];
            let (ml, mr) = members.split_at_mut(mid);
            let (il, ir) = input.split_at(cut.min(input.len()));
            let (ol, or) = output.split(cut);
            let (l, r) = rayon::join(
                || each_member(ml, &offset[..=mid], il, ol, f),
                || each_member(mr, &offset[mid..], ir, or, f),
            );
            l + r
        }
    }
}

/// [`each_member`] for work that reads and writes none of the island's vectors.
fn on_each_member<F>(members: &mut [Member<'_>], offset: &[usize], f: &F)
where
    F: Fn(&mut Member<'_>) + Sync,
{
    each_member(
        members,
        offset,
        &[] as &[Vec3],
        &mut [] as &mut [Vec3],
        &|_, m, _, _| {
            f(m);
            0.0
        },
    );
}

/// `s.ap = A s.p`: the island's tangent (the members' `M + c K` and the pushing springs'
/// rows) at the last linearisation.
fn apply_island(
    members: &mut [Member<'_>],
    springs: &ContactSprings,
    s: &mut SolveScratch,
    dt: f32,
    gravity: Vec3,
) {
    s.transfer.load(&s.p);
    let transfer = &s.transfer;
    s.spring_force.resize(s.springs.len(), Vec3::ZERO);
    s.springs
        .par_iter()
        .zip(s.spring_force.par_iter_mut())
        .with_min_len(SPRING_TASK)
        .filter(|(e, _)| e.pushing)
        .for_each(|(e, f)| {
            let sp = &springs.springs[e.index as usize];
            *f = e.tangent(sp, e.relative_change(transfer, springs), dt);
        });
    let (spread, p, rows) = Spread::pass(springs, s, Target::Product);
    each_member(members, spread.offset, p, rows, &|at, m, p, (ap, sums)| {
        let ctx = StepContext::new(dt, gravity, m.material);
        m.dynamics.apply(m.phyxels, &ctx, p, ap);
        spread.add(at, m, sums, ap);
        0.0
    });
}

/// Contact springs per parallel task of their forces: a spring reads some fifty
/// phyxels' velocities (about half a µs), so smaller tasks cost more to hand over.
const SPRING_TASK: usize = 64;

/// Which springs [`Spread`] adds.
#[derive(Clone, Copy, PartialEq)]
enum Target {
    /// Every spring (the residual).
    Residual,
    /// The pushing springs (the others are out of the tangent).
    Product,
}

/// The springs' `s.spring_force` on side a, and its opposite on side b, to be added to
/// a member's rows by [`Spread::add`].
struct Spread<'a> {
    springs: &'a ContactSprings,
    active: &'a [Active],
    forces: &'a [Vec3],
    sides: &'a MemberSides,
    offset: &'a [usize],
    transfer: &'a Transfer,
    target: Target,
}

/// What [`Spread::pass`] hands each member: its rows of the vector it adds the springs'
/// forces to, and of the sums it adds them with.
type SpreadRows<'a> = (&'a mut [Vec3], &'a mut [f32x8]);

impl<'a> Spread<'a> {
    /// A pass over the members that adds the springs' forces of `s.spring_force`: the
    /// spreading, the vector the members read (`s.v` for the residual, `s.p` for the
    /// product) and the rows they write (`s.g` or `s.ap`, and `s.sums`).
    fn pass(
        springs: &'a ContactSprings,
        s: &'a mut SolveScratch,
        target: Target,
    ) -> (Self, &'a [Vec3], SpreadRows<'a>) {
        let (input, out) = match target {
            Target::Residual => (&s.v, &mut s.g),
            Target::Product => (&s.p, &mut s.ap),
        };
        let spread = Spread {
            springs,
            active: &s.springs,
            forces: &s.spring_force,
            sides: &s.sides,
            offset: &s.offset,
            transfer: &s.transfer,
            target,
        };
        (spread, input, (&mut out[..], &mut s.sums[..]))
    }

    /// Adds the forces of the member whose first row is `at` to its `rows`, summed in
    /// `sums` in the springs' order ([`transfer::spread`]), so that each row sums in the
    /// same order on any number of threads, then added ([`transfer::finish`]).
    fn add(&self, at: usize, m: &Member<'_>, sums: &mut [f32x8], rows: &mut [Vec3]) {
        let sides = self.sides.of(self.offset.partition_point(|&o| o < at));
        if sides.is_empty() {
            return;
        }
        sums.fill(f32x8::ZERO);
        for &code in sides {
            let e = &self.active[code as usize / 2];
            if self.target == Target::Product && !e.pushing {
                continue;
            }
            let f = self.forces[code as usize / 2];
            match (code % 2, &e.b) {
                (0, _) => transfer::spread(sums, self.springs, &e.a, f),
                (_, Some(b)) => transfer::spread(sums, self.springs, b, -f),
                _ => unreachable!("a side b in a member's list is a member"),
            }
        }
        let local = self.transfer.local(at, m.phyxels.len());
        transfer::finish(sums, local, &m.phyxels.fixed, rows);
    }
}

/// The residual's f32 floor, `‖δg‖_{M⁻¹}`: what rounding the displacements the forces
/// are computed from ([`Implicit::displacement_rounding`]) does to the residual through
/// the island's stiffness, `δg = (A − M) δx / dt`, with `δx` of that size and a fixed
/// pseudo-random sign per coordinate (rounding errors are not
/// correlated, so neither are the signs). A solve that stagnates near this is at the
/// forces' rounding; one that stagnates far above it has stalled.
fn rounding_floor(
    members: &mut [Member<'_>],
    springs: &ContactSprings,
    s: &mut SolveScratch,
    dt: f32,
    gravity: Vec3,
) -> f64 {
    for (k, m) in members.iter().enumerate() {
        let r = s.offset[k]..s.offset[k + 1];
        m.dynamics
            .displacement_rounding(m.phyxels, &mut s.p[r.clone()]);
        for (j, i) in r.enumerate() {
            s.p[i] = if m.phyxels.fixed[j] == 0 {
                s.p[i] / dt * rounding_signs(i)
            } else {
                Vec3::ZERO
            };
        }
    }
    apply_island(members, springs, s, dt, gravity);
    inverse_mass_norm(members, &s.offset, |i, mass| s.ap[i] - s.p[i] * mass)
}

/// `‖x‖_{M⁻¹}` over the island's free phyxels, `x` given per island entry `i` (with its
/// phyxel's mass): the residual's norm.
fn inverse_mass_norm(
    members: &[Member<'_>],
    offset: &[usize],
    x: impl Fn(usize, f32) -> Vec3,
) -> f64 {
    let mut norm = 0.0f64;
    for (k, m) in members.iter().enumerate() {
        for j in 0..m.phyxels.len() {
            if m.phyxels.fixed[j] == 0 {
                let mass = m.phyxels.mass[j];
                norm += x(offset[k] + j, mass).length_squared() as f64 / mass as f64;
            }
        }
    }
    norm.sqrt()
}

/// Which of `springs` push and which slide, as one number (an FNV-1a hash of the two
/// flags in the springs' order): equal between two iterates when no spring changed.
fn contact_state(springs: &[Active]) -> u64 {
    springs.iter().fold(0xcbf2_9ce4_8422_2325, |h, e| {
        let flags = u64::from(e.pushing) | u64::from(e.slide != Vec3::ZERO) << 1;
        (h ^ flags).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Three signs (±1) for entry `i`, from a fixed integer hash (SplitMix64's finaliser).
fn rounding_signs(i: usize) -> Vec3 {
    let mut h = (i as u64).wrapping_add(0x9e37_79b9_7f4a_7c15);
    h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    h ^= h >> 31;
    let sign = |bit: u64| if h >> bit & 1 == 0 { 1.0 } else { -1.0 };
    Vec3::new(sign(0), sign(1), sign(2))
}

/// Removes the last residual's share along the island's uniform translation: the
/// internal forces and the springs between members do not change under it, so the
/// correction `−Σ g / Σ m` is exact, and the island's momentum changes by its external
/// impulse alone, whatever residual Newton stopped at. Not for an island held by
/// anything outside it (a fixed phyxel, a spring to a static object or a tool).
fn remove_translation(members: &[Member<'_>], s: &mut SolveScratch) {
    let held = s.springs.iter().any(|e| e.b.is_none())
        || members
            .iter()
            .any(|m| m.phyxels.fixed.iter().any(|&f| f != 0));
    if held {
        return;
    }
    let (mut sum, mut mass) = (DVec3::ZERO, 0.0f64);
    for (k, m) in members.iter().enumerate() {
        let at = s.offset[k];
        for j in 0..m.phyxels.len() {
            sum += s.g[at + j].as_dvec3();
            mass += m.phyxels.mass[j] as f64;
        }
    }
    if mass > 0.0 {
        let dv = (-sum / mass).as_vec3();
        for v in &mut s.v {
            *v += dv;
        }
    }
}

/// Gives each member the springs' rows at the step's start, lumped per phyxel, for its
/// preconditioner ([`Implicit::contact_blocks`]).
fn contact_blocks(
    members: &mut [Member<'_>],
    springs: &ContactSprings,
    s: &mut SolveScratch,
    dt: f32,
) {
    let any = s.springs.iter().any(|e| e.pushing);
    s.blocks.clear();
    if any {
        s.blocks.resize(s.v.len(), Mat3::ZERO);
        for e in &s.springs {
            let sp = &springs.springs[e.index as usize];
            if let Some(t) = e.tangent_matrix(sp, dt) {
                lump(&mut s.blocks, springs, members, &s.transfer, &e.a, t);
                if let Some(b) = &e.b {
                    lump(&mut s.blocks, springs, members, &s.transfer, b, t);
                }
            }
        }
    }
    let blocks: &[Mat3] = if any { &s.blocks } else { &[] };
    each_member(
        members,
        &s.offset,
        blocks,
        &mut [] as &mut [Vec3],
        &|_, m, blocks, _| {
            m.dynamics.contact_blocks(m.phyxels, blocks);
            0.0
        },
    );
}

/// A spring side on `member` (its rows from `offset[member]`), with its weights'
/// centroid at the members' positions.
fn side(
    offset: &[usize],
    member: usize,
    spring: SpringSide,
    transfer: &Transfer,
    springs: &ContactSprings,
) -> Side {
    let offset = offset[member];
    Side {
        offset,
        member,
        spring,
        centroid: transfer.centroid(springs, &spring, offset),
    }
}

/// Solves `A δ = −g` over the island by preconditioned CG from δ = 0, to `forcing` of
/// `‖g‖`; returns the iterations. `A` is the members' tangents plus the pushing
/// springs' rows (normal spring, dashpot and friction); the preconditioner is the members' own
/// (block diagonal). Stops early on a direction of non-positive curvature (an
/// indefinite tangent: a buckling body), keeping the last iterate.
fn solve_cg(
    members: &mut [Member<'_>],
    springs: &ContactSprings,
    s: &mut SolveScratch,
    max_cg: u32,
    forcing: f64,
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
        each_member(members, &s.offset, &s.r, &mut s.z[..], &|_, m, r, z| {
            m.dynamics.precondition(m.phyxels, r, z);
            0.0
        });
    };
    let apply = |members: &mut [Member<'_>], s: &mut SolveScratch| {
        apply_island(members, springs, s, dt, gravity)
    };
    let mut deferred = members.iter().any(|m| m.dynamics.preconditioner_deferred());
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
        if dot(&s.r, &s.r).sqrt() <= forcing * r0 {
            break;
        }
        if deferred && it == DEFERRED_CG {
            // The mass alone does not solve this step: the full preconditioners, with
            // the step's contact blocks, and CG again from δ = 0.
            deferred = false;
            on_each_member(members, &s.offset, &|m| {
                if m.dynamics.preconditioner_deferred() {
                    let ctx = StepContext::new(dt, gravity, m.material);
                    m.dynamics.prepare_preconditioner(m.phyxels, &ctx);
                }
            });
            contact_blocks(members, springs, s, dt);
            for j in 0..s.v.len() {
                s.delta[j] = Vec3::ZERO;
                s.r[j] = -s.g[j];
            }
            precondition(members, s);
            s.p.copy_from_slice(&s.z);
            rz = dot(&s.r, &s.z);
            continue;
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
