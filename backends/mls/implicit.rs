//! `mls-implicit`: the MLS elasticity of [`MlsDynamics`] stepped by backward Euler, so
//! that a stiff body takes frame-rate steps.
//!
//! Each step solves for the new velocities `v` the nonlinear system
//! `g(v) = M (v − vₙ) − dt (f(xₙ + dt v, v) + f_ext + M g) = 0` by Newton's method. Each
//! Newton step solves `(M + (dt² + dt τ) K) δ = −g` by conjugate gradients, with
//! `K = −∂f/∂x` the tangent stiffness of the MLS law at the current iterate. `K` is
//! applied matrix-free through the stencil (`MlsImplicit::tangent`). The
//! preconditioner is the same system at rest, `M + (dt² + dt τ) K₀`, assembled once per
//! dt and factored by a skyline Cholesky in reverse Cuthill–McKee order, turned by the
//! body's best-fit rotation; when the contact springs' rows are a sizeable share of it
//! ([`CONTACT_SHARE`]: a sticking contact's friction) they are added, lumped per phyxel,
//! and the sum factored again (only when they have changed by [`REFACTOR_CHANGE`]).
//! Near rest it is close to the true system, and CG needs a few iterations.
//!
//! The residual uses the exact forces of `MlsDynamics` (the SIMD lane kernel, plastic
//! flow and Kelvin–Voigt viscosity included), so a converged step is the backward-Euler
//! step of the same discretisation as `mls`. The Jacobian leaves out two small terms:
//! `k_v (det J − 1) ∂cof J`, and the geometric part of the viscous term. They slow
//! Newton's convergence slightly but do not change the solution.
//!
//! The Newton–CG loop is the library's ([`phyxel::solver::solve`]): this
//! backend gives its operators ([`Implicit`]). In a world, bodies of this backend that
//! touch are solved together, with their contact springs (and those against static
//! objects) in the system, so stiff contact does not limit dt; against an explicit body
//! the contact force is explicit (held over the step).

use super::*;
use phyxel::dynamics::SolverStats;
use phyxel::dynamics::implicit::{F32_UNIT_ROUNDOFF, Implicit, SolveReport, SolveSettings};
pub use phyxel::dynamics::implicit::{FLOOR_TOLERANCE, MAX_CG, MAX_NEWTON, NEWTON_TOLERANCE};
use phyxel::math::linalg::polar_rotation;
use phyxel::par;
use phyxel::solver::skyline::{Rounding, Skyline, rcm_order};
use phyxel::solver::{self, Member, SolveScratch};

/// The backend's name in scenes and on the command line.
pub const NAME: &str = "mls-implicit";

/// Relative change of the contact blocks (summed Frobenius norms) above which the
/// contact factor is made again: a factor costs as much as hundreds of CG iterations
/// on a large body, and one made for blocks within this change still preconditions
/// well.
pub const REFACTOR_CHANGE: f32 = 0.25;

/// The contact blocks enter the factor only when their trace is at least this share of
/// the body's own diagonal at the phyxels they touch. The lumped blocks overestimate the
/// springs' coupling: a soft frictionless contact (`hertz`: 3%) converges faster
/// without them, while a sticking contact's friction at a frame-rate step (`pile`: up
/// to 80 times the body's own) is what CG otherwise spends hundreds of iterations on.
/// (At dt = 1e-4 s, `incline`'s sticking block takes 10.0 CG iterations per step with
/// them against 7.7 without: docs/BACKENDS.md.)
pub const CONTACT_SHARE: f64 = 0.25;

/// The largest share of a body's mass that the preconditioner's rounding may stand for
/// when the factor is kept in bfloat16: `u · tr A / tr M` over the free phyxels (the
/// rounding's share of a rigid motion's Rayleigh quotient), f32 above.
pub const BF16_SHARE: f64 = 0.5;

/// How to round the factor of `m` (`M + c K₀`, perhaps with contact blocks; rows in RCM
/// `position`): the rounding perturbs `L Lᵀ` by about the unit roundoff times its
/// diagonal, and a rigid motion of the body is held by the mass alone (`K₀` does not
/// resist it), so the perturbation's share of its Rayleigh quotient is about
/// `u · tr A / tr M` over the free phyxels. bfloat16 while that is at most
/// [`BF16_SHARE`] (soft bodies at a frame-rate step: `pile-20`'s 0.2–0.35, the squeezed
/// cube's 0.13), f32 above (the stiff cantilever's 33: in bfloat16 a stiff sphere's
/// impact stalled Newton at 5% of its scale).
fn rounding_for(m: &Skyline, position: &[u32], phyxels: &Phyxels) -> Rounding {
    let (mut trace, mut mass) = (0.0f64, 0.0f64);
    for (node, &at) in position.iter().enumerate() {
        if phyxels.fixed[node] == 0 {
            trace += (0..3).map(|a| m.diagonal(3 * at as usize + a)).sum::<f64>();
            mass += 3.0 * phyxels.mass[node] as f64;
        }
    }
    if mass > 0.0 && Rounding::Bf16.unit_roundoff() * trace <= BF16_SHARE * mass {
        Rounding::Bf16
    } else {
        Rounding::F32
    }
}

/// Warm-started polar iterations (of four steps each) for the body's rotation per step.
const ROTATION_FITS: usize = 4;

/// The linearisation of the law at phyxel i: `J`, `σ` (Hooke of the elastic strain), the
/// cofactor of `J` and the volume weight.
#[derive(Clone, Copy, Default)]
struct Linear {
    j: Mat3,
    sigma: Mat3,
    cof: Mat3,
    volume: f32,
}

/// The rest-state system `M + c K₀` (c = dt² + dt τ), factored, and the same with a
/// step's contact blocks added.
struct Preconditioner {
    /// `M + c K₀` assembled, not factored: the step's contact blocks are added to a copy.
    system: Skyline,
    factor: Skyline,
    /// The factor of `system` plus `blocks`, the contact blocks it was made with (rest
    /// frame; empty: none made yet, and no rows until the first contact factor). The
    /// step uses it when `with_contact`.
    contact: Skyline,
    blocks: Vec<Mat3>,
    with_contact: bool,
    /// Node at each position, and position of each node (RCM order).
    position: Vec<u32>,
    /// The `c` and `τ` it was built for.
    built_for: (f32, f32),
}

/// MLS elasticity stepped by backward Euler (see the module doc).
pub struct MlsImplicit {
    mls: MlsDynamics,
    pre: Option<Preconditioner>,
    /// Whether a preconditioner has been built (or tried): until then a solve runs on
    /// the mass alone and builds it only if that does not converge
    /// ([`Implicit::preconditioner_deferred`]); after, every new dt or rest state
    /// rebuilds it at once.
    factored: bool,
    /// The body's rotation from rest at the step's start (the best fit of its phyxels):
    /// the preconditioner is the rest-state system turned by it.
    rotation: Quat,
    /// Newton tolerance on the relative residual (default [`NEWTON_TOLERANCE`]).
    pub tolerance: f32,
    /// Newton and CG iteration caps (defaults [`MAX_NEWTON`], [`MAX_CG`]).
    pub max_newton: u32,
    pub max_cg: u32,
    stats: SolverStats,
    /// The solve's buffers when stepped alone ([`Dynamics::step`]).
    scratch: SolveScratch,
    // Per-step buffers, sized once (no allocation in the step).
    x0: Vec<Vec3>,
    carry0: Vec<Vec3>,
    v0: Vec<Vec3>,
    f_ext: Vec<Vec3>,
    dp: Vec<Mat3>,
    linear: Vec<Linear>,
    plastic0: Vec<Mat3>,
    dofs: Vec<f32>,
    /// The step's contact blocks turned to rest.
    rest_blocks: Vec<Mat3>,
}

impl MlsImplicit {
    /// Builds the rest stencil of `phyxels` (as `mls`); the preconditioner is built at
    /// the first step (it depends on dt).
    pub fn new(phyxels: &Phyxels, material: &Material) -> Self {
        let n = phyxels.len();
        let zero = vec![Vec3::ZERO; n];
        Self {
            mls: MlsDynamics::new(phyxels, material),
            pre: None,
            factored: false,
            rotation: Quat::IDENTITY,
            tolerance: NEWTON_TOLERANCE,
            max_newton: MAX_NEWTON,
            max_cg: MAX_CG,
            stats: SolverStats {
                tolerance: NEWTON_TOLERANCE,
                ..SolverStats::default()
            },
            scratch: SolveScratch::default(),
            x0: zero.clone(),
            carry0: zero.clone(),
            v0: zero.clone(),
            f_ext: zero,
            dp: vec![Mat3::ZERO; n],
            linear: vec![Linear::default(); n],
            plastic0: Vec::new(),
            dofs: vec![0.0; 3 * n],
            rest_blocks: Vec::with_capacity(n),
        }
    }

    /// The explicit backend underneath (stencil, stress, plastic strain).
    pub fn mls(&self) -> &MlsDynamics {
        &self.mls
    }

    /// Whether the factored preconditioner is built (it waits until a solve needs it:
    /// [`Implicit::preconditioner_deferred`]).
    pub fn has_factor(&self) -> bool {
        self.pre.is_some()
    }

    /// Work and convergence of the solves so far.
    pub fn solver_stats(&self) -> SolverStats {
        self.stats
    }

    /// The strain scale of the law: `P = −v s J σ` (2 for the paper's strain, whose
    /// energy is ½ ε:σ of `JᵀJ − I`).
    fn strain_scale(material: &Material) -> f32 {
        if material.strain == StrainForm::Paper {
            2.0
        } else {
            1.0
        }
    }

    /// Builds `M + c K₀` in RCM order and factors it. Fixed phyxels get an identity row.
    fn build_preconditioner(
        &self,
        phyxels: &Phyxels,
        material: &Material,
        c: f32,
        tau: f32,
    ) -> Option<Preconditioner> {
        let st = &self.mls.stencil;
        let n = st.len();
        let free = |j: usize| phyxels.fixed[j] == 0;
        // Nodes coupled through a row (the row's phyxel and its neighbours): each free
        // node's partners, gathered over the rows it is in with a stamp per node.
        let row_nodes =
            |i: usize| std::iter::once(i).chain(st.row(i).map(|k| st.neighbours[k] as usize));
        let mut rows_of: Vec<Vec<u32>> = vec![Vec::new(); n];
        for i in 0..n {
            for j in row_nodes(i).filter(|&j| free(j)) {
                rows_of[j].push(i as u32);
            }
        }
        let mut stamp = vec![usize::MAX; n];
        let mut adjacency: Vec<Vec<u32>> = vec![Vec::new(); n];
        for a in 0..n {
            stamp[a] = a;
            for &i in &rows_of[a] {
                for b in row_nodes(i as usize).filter(|&b| free(b)) {
                    if stamp[b] != a {
                        stamp[b] = a;
                        adjacency[a].push(b as u32);
                    }
                }
            }
            adjacency[a].sort_unstable();
        }
        let order = rcm_order(&adjacency);
        let mut position = vec![0u32; n];
        for (k, &v) in order.iter().enumerate() {
            position[v as usize] = k as u32;
        }
        let mut first = vec![0usize; 3 * n];
        for node in 0..n {
            let p = position[node] as usize;
            let lowest = adjacency[node]
                .iter()
                .map(|&b| position[b as usize] as usize)
                .fold(p, usize::min);
            for a in 0..3 {
                first[3 * p + a] = 3 * lowest;
            }
        }
        let mut m = Skyline::new(first);
        for (node, &at) in position.iter().enumerate() {
            let p = 3 * at as usize;
            let mass = if free(node) {
                phyxels.mass[node] as f64
            } else {
                1.0
            };
            for a in 0..3 {
                m.add(p + a, p + a, mass);
            }
        }
        let (lambda, mu) = material.lame();
        let s = if material.strain == StrainForm::Paper {
            4.0
        } else {
            1.0
        };
        let (a_coef, m_coef) = ((s * lambda + material.k_volume()) as f64, (s * mu) as f64);
        let c = c as f64;
        let mut nodes: Vec<(usize, [f64; 3])> = Vec::new();
        for i in 0..n {
            // The row's free nodes, last position first: each pair is visited once with
            // its upper node's rows, whose columns then run forward in the envelope.
            nodes.clear();
            nodes.extend(
                std::iter::once((i, st.d_self[i]))
                    .chain(st.row(i).map(|k| (st.neighbours[k] as usize, st.d[k])))
                    .filter(|&(j, _)| free(j))
                    .map(|(j, c)| (3 * position[j] as usize, c.as_dvec3().to_array())),
            );
            nodes.sort_unstable_by_key(|&(p, _)| std::cmp::Reverse(p));
            let w = c * phyxels.volume[i] as f64;
            for (at, &(pj, cj)) in nodes.iter().enumerate() {
                let dots = |ck: &[f64; 3]| cj[0] * ck[0] + cj[1] * ck[1] + cj[2] * ck[2];
                for &(pk, ck) in &nodes[at..] {
                    let dot = dots(&ck);
                    for a in 0..3 {
                        let entry = |e: usize| {
                            let same = if a == e { dot } else { 0.0 };
                            w * (a_coef * cj[a] * ck[e] + m_coef * (same + cj[e] * ck[a]))
                        };
                        let row = [entry(0), entry(1), entry(2)];
                        let width = if pj == pk { a + 1 } else { 3 };
                        m.add_row(pj + a, pk, &row[..width]);
                    }
                }
            }
        }
        if let Some(k) = &self.mls.stabilisation {
            // `c K` of the residual stabilisation, the same for x, y and z: the diagonal
            // is minus the row's sum (fixed partners included), the lower triangle over
            // the free partners. Its couplings lie within the rows' envelope above.
            for j in (0..n).filter(|&j| free(j)) {
                let pj = 3 * position[j] as usize;
                let mut diagonal = 0.0f64;
                for (l, kjl) in k.row(j) {
                    diagonal -= kjl as f64;
                    let pl = 3 * position[l] as usize;
                    if free(l) && pl < pj {
                        (0..3).for_each(|a| m.add(pj + a, pl + a, c * kjl as f64));
                    }
                }
                (0..3).for_each(|a| m.add(pj + a, pj + a, c * diagonal));
            }
        }
        let system = m.clone();
        let rounding = rounding_for(&m, &position, phyxels);
        m.factor(rounding).ok()?;
        Some(Preconditioner {
            contact: Skyline::new(Vec::new()),
            blocks: Vec::new(),
            factor: m,
            system,
            with_contact: false,
            position,
            built_for: (c as f32, tau),
        })
    }

    /// The rotation from rest that best fits the phyxels (mass-weighted, about their
    /// centres), warm-started from the last step's.
    fn fit_rotation(&mut self, phyxels: &Phyxels) {
        let (mut m, mut c, mut c0) = (0.0f32, Vec3::ZERO, Vec3::ZERO);
        for j in 0..phyxels.len() {
            let w = phyxels.mass[j];
            m += w;
            c += phyxels.pos.get(j) * w;
            c0 += phyxels.rest.get(j) * w;
        }
        if m.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return;
        }
        let (c, c0) = (c / m, c0 / m);
        let mut a = Mat3::ZERO;
        for j in 0..phyxels.len() {
            let (x, x0) = (phyxels.pos.get(j) - c, phyxels.rest.get(j) - c0);
            a += Mat3::from_cols(x * x0.x, x * x0.y, x * x0.z) * phyxels.mass[j];
        }
        for _ in 0..ROTATION_FITS {
            self.rotation = polar_rotation(a, self.rotation);
        }
    }

    /// `z = R P⁻¹ Rᵀ r`: the rest-state factor (with the step's contact blocks) turned by
    /// the body's rotation, or the mass (Jacobi) without one.
    fn precondition_into(&mut self, phyxels: &Phyxels, r: &[Vec3], z: &mut [Vec3]) {
        let free = |j: usize| phyxels.fixed[j] == 0;
        let rot = Mat3::from_quat(self.rotation);
        let back = rot.transpose();
        match &self.pre {
            Some(pre) => {
                for (j, r) in r.iter().enumerate() {
                    let p = 3 * pre.position[j] as usize;
                    let r = if free(j) { back * *r } else { Vec3::ZERO };
                    self.dofs[p..p + 3].copy_from_slice(&r.to_array());
                }
                let factor = if pre.with_contact {
                    &pre.contact
                } else {
                    &pre.factor
                };
                factor.solve_rounded(&mut self.dofs);
                for (j, z) in z.iter_mut().enumerate() {
                    let p = 3 * pre.position[j] as usize;
                    let d = &self.dofs[p..p + 3];
                    *z = if free(j) {
                        rot * Vec3::new(d[0], d[1], d[2])
                    } else {
                        Vec3::ZERO
                    };
                }
            }
            None => {
                for j in 0..z.len() {
                    z[j] = if free(j) {
                        r[j] / phyxels.mass[j]
                    } else {
                        Vec3::ZERO
                    };
                }
            }
        }
    }

    /// The law linearised at the state of the last force evaluation.
    fn linearise_law(&mut self, phyxels: &Phyxels, material: &Material) {
        let law = Law::new(material, 0.0, 0.0);
        let (grad, plastic) = (&self.mls.grad, &self.mls.plastic);
        self.linear
            .par_iter_mut()
            .with_min_len(par::point_task())
            .enumerate()
            .for_each(|(i, l)| {
                let j = Mat3::IDENTITY + grad[i];
                let mut e = law.strain(grad[i]);
                if let Some(ep) = plastic.get(i) {
                    e -= *ep;
                }
                *l = Linear {
                    j,
                    sigma: law.hooke(e),
                    cof: cofactor(j),
                    volume: phyxels.volume[i],
                };
            });
    }

    /// `ap = A p = M p + c K p` with `K` the tangent stiffness at the last
    /// linearisation: `dPᵢ = −vᵢ (s (dJ σ + J σ(dε)) + k_v (cof J : dJ) cof J)`, gathered
    /// over the stencil as the forces are. Fixed phyxels are held (identity rows).
    fn tangent(
        &mut self,
        phyxels: &Phyxels,
        material: &Material,
        c: f32,
        w: &[Vec3],
        ap: &mut [Vec3],
    ) {
        let st = &self.mls.stencil;
        let law = Law::new(material, 0.0, 0.0);
        let s = Self::strain_scale(material);
        let kv = material.k_volume();
        let linear = &self.linear;
        self.dp
            .par_iter_mut()
            .with_min_len(par::point_task())
            .enumerate()
            .for_each(|(i, dp)| {
                let l = &linear[i];
                let dj = st.gradient_of(i, |j| w[j]);
                let dc = law.strain_rate(l.j, dj);
                let mut d = (dj * l.sigma + l.j * law.hooke(dc)) * s;
                if kv > 0.0 {
                    let cof_dj = (0..3).map(|k| l.cof.col(k).dot(dj.col(k))).sum::<f32>();
                    d += l.cof * (kv * cof_dj);
                }
                *dp = d * (-l.volume);
            });
        let (in_off, incoming, dp) = (&self.mls.in_off, &self.mls.incoming, &self.dp);
        let fixed = &phyxels.fixed;
        let mass = &phyxels.mass;
        let stabilisation = self.mls.stabilisation.as_ref();
        ap.par_iter_mut()
            .with_min_len(par::point_task())
            .enumerate()
            .for_each(|(j, out)| {
                if fixed[j] != 0 {
                    *out = Vec3::ZERO;
                    return;
                }
                let mut df = dp[j] * st.d_self[j];
                for &(i, k) in &incoming[in_off[j] as usize..in_off[j + 1] as usize] {
                    df += dp[i as usize] * st.d[k as usize];
                }
                *out = w[j] * mass[j] - df * c;
                if let Some(k) = stabilisation {
                    *out += k.product_at(j, |l| w[l]) * c;
                }
            });
    }
}

impl Implicit for MlsImplicit {
    fn begin(&mut self, phyxels: &Phyxels, ctx: &StepContext<'_>) {
        let dt = ctx.dt;
        let tau = self.mls.tau(ctx.material);
        let c = dt * dt + dt * tau;
        if self.pre.as_ref().is_none_or(|p| p.built_for != (c, tau)) {
            // The first factor waits until a solve needs it (`preconditioner_deferred`).
            self.pre = if self.factored {
                self.build_preconditioner(phyxels, ctx.material, c, tau)
            } else {
                None
            };
        }
        self.fit_rotation(phyxels);
        for j in 0..phyxels.len() {
            self.x0[j] = phyxels.pos.get(j);
            self.carry0[j] = phyxels.pos_carry.get(j);
            self.v0[j] = phyxels.vel.get(j);
            self.f_ext[j] = phyxels.force.get(j);
        }
        if !self.mls.plastic.is_empty() {
            self.plastic0.clear();
            self.plastic0.extend_from_slice(&self.mls.plastic);
        }
    }

    /// Sets the trial state `x = xₙ + dt v`, `v`, and evaluates the forces.
    fn residual(
        &mut self,
        phyxels: &mut Phyxels,
        ctx: &StepContext<'_>,
        v: &[Vec3],
        g: &mut [Vec3],
    ) -> f64 {
        let dt = ctx.dt;
        // The step's displacement goes into the position carry, which the force kernel
        // adds to `pos − rest`: rounded into the f32 position it would lose up to half an
        // ulp (3e-8 m at 0.5 m), which a stiff bar (E = 1e8 Pa) turns into force noise as
        // large as its weight, and Newton stalls at a fifth of the first residual.
        for (j, &v) in v.iter().enumerate() {
            if phyxels.fixed[j] == 0 {
                phyxels.pos_carry.set(j, self.carry0[j] + v * dt);
                phyxels.vel.set(j, v);
            }
        }
        if !self.plastic0.is_empty() {
            self.mls.plastic.copy_from_slice(&self.plastic0);
        }
        self.mls.compute_forces(phyxels, ctx.material, dt);
        let f = &self.mls.internal;
        let mut external = 0.0f64;
        for j in 0..phyxels.len() {
            if phyxels.fixed[j] != 0 {
                g[j] = Vec3::ZERO;
                continue;
            }
            let m = phyxels.mass[j];
            let outside = self.f_ext[j] + ctx.gravity * m;
            g[j] = (v[j] - self.v0[j]) * m - (f.get(j) + outside) * dt;
            external += outside.length_squared() as f64 / m as f64;
        }
        external
    }

    fn linearise(&mut self, phyxels: &Phyxels, ctx: &StepContext<'_>) {
        self.linearise_law(phyxels, ctx.material);
    }

    /// The force kernel reads `(pos − rest) + pos_carry`: each term, and their sum,
    /// is rounded to f32.
    fn displacement_rounding(&self, phyxels: &Phyxels, out: &mut [Vec3]) {
        for (j, r) in out.iter_mut().enumerate() {
            let u = phyxels.pos.get(j) - phyxels.rest.get(j);
            let carry = phyxels.pos_carry.get(j);
            *r = (u.abs() + carry.abs() + (u + carry).abs()) * F32_UNIT_ROUNDOFF;
        }
    }

    fn apply(&mut self, phyxels: &Phyxels, ctx: &StepContext<'_>, p: &[Vec3], ap: &mut [Vec3]) {
        let c = ctx.dt * ctx.dt + ctx.dt * self.mls.tau(ctx.material);
        self.tangent(phyxels, ctx.material, c, p, ap);
    }

    fn precondition(&mut self, phyxels: &Phyxels, r: &[Vec3], z: &mut [Vec3]) {
        self.precondition_into(phyxels, r, z);
    }

    fn preconditioner_deferred(&self) -> bool {
        !self.factored
    }

    fn prepare_preconditioner(&mut self, phyxels: &Phyxels, ctx: &StepContext<'_>) {
        let tau = self.mls.tau(ctx.material);
        let c = ctx.dt * ctx.dt + ctx.dt * tau;
        self.factored = true;
        self.pre = self.build_preconditioner(phyxels, ctx.material, c, tau);
    }

    /// Uses the factor of `M + c K₀ + Rᵀ B R` (the blocks turned to rest), refactored
    /// only when the blocks have changed by more than [`REFACTOR_CHANGE`] since it was
    /// made; no blocks: the body's own factor. A factor that fails keeps the body's own.
    fn contact_blocks(&mut self, phyxels: &Phyxels, blocks: &[Mat3]) {
        let rot = Mat3::from_quat(self.rotation);
        let Some(pre) = self.pre.as_mut() else {
            return;
        };
        pre.with_contact = false;
        if blocks.iter().all(|b| *b == Mat3::ZERO) {
            return;
        }
        let rest = &mut self.rest_blocks;
        rest.clear();
        rest.extend(blocks.iter().enumerate().map(|(j, b)| {
            if phyxels.fixed[j] != 0 {
                Mat3::ZERO
            } else {
                rot.transpose() * *b * rot
            }
        }));
        {
            let (mut contact, mut own) = (0.0f64, 0.0f64);
            for (j, b) in rest.iter().enumerate() {
                if *b != Mat3::ZERO {
                    let p = 3 * pre.position[j] as usize;
                    contact += (b.x_axis.x + b.y_axis.y + b.z_axis.z) as f64;
                    own += (0..3).map(|a| pre.system.diagonal(p + a)).sum::<f64>();
                }
            }
            if contact < CONTACT_SHARE * own {
                return;
            }
        }
        if pre.blocks.len() == rest.len() {
            let norm = |m: Mat3| m.to_cols_array().iter().map(|x| x * x).sum::<f32>().sqrt();
            let (mut change, mut size) = (0.0f32, 0.0f32);
            for (new, old) in rest.iter().zip(&pre.blocks) {
                change += norm(*new - *old);
                size += norm(*new).max(norm(*old));
            }
            if change <= REFACTOR_CHANGE * size {
                pre.with_contact = true;
                return;
            }
        }
        if pre.contact.len() == pre.system.len() {
            pre.contact.copy_from(&pre.system);
        } else {
            pre.contact = pre.system.clone();
        }
        for (j, b) in rest.iter().enumerate() {
            if *b == Mat3::ZERO {
                continue;
            }
            let p = 3 * pre.position[j] as usize;
            for a in 0..3 {
                for e in 0..=a {
                    pre.contact.add(p + a, p + e, b.col(e)[a] as f64);
                }
            }
        }
        let rounding = rounding_for(&pre.contact, &pre.position, phyxels);
        pre.with_contact = pre.contact.factor(rounding).is_ok();
        pre.blocks.clear();
        if pre.with_contact {
            pre.blocks.extend_from_slice(rest);
        }
    }

    /// Positions by the compensated sum (as the explicit step's).
    fn commit(&mut self, phyxels: &mut Phyxels, ctx: &StepContext<'_>, v: &[Vec3]) {
        for (j, &v) in v.iter().enumerate() {
            if phyxels.fixed[j] != 0 {
                phyxels.vel.set(j, Vec3::ZERO);
                continue;
            }
            let (x, carry) = (self.x0[j], self.carry0[j]);
            let y = v * ctx.dt + carry;
            let t = x + y;
            phyxels.pos_carry.set(j, y - (t - x));
            phyxels.pos.set(j, t);
            phyxels.vel.set(j, v);
        }
        phyxels.force.fill_zero();
    }

    fn record(&mut self, report: &SolveReport) {
        self.stats.record(report);
    }

    fn settings(&self) -> SolveSettings {
        SolveSettings {
            tolerance: self.tolerance,
            max_newton: self.max_newton,
            max_cg: self.max_cg,
        }
    }
}

impl Dynamics for MlsImplicit {
    fn name(&self) -> &str {
        NAME
    }

    /// One backward-Euler step of this body alone (the world steps it with
    /// [`phyxel::solver`] and the bodies it touches).
    fn step(&mut self, phyxels: &mut Phyxels, ctx: &StepContext<'_>) {
        let mut scratch = std::mem::take(&mut self.scratch);
        let mut members = [Member {
            object: 0,
            dynamics: self as &mut dyn Implicit,
            phyxels,
            material: ctx.material,
        }];
        let none = solver::ContactSprings::default();
        solver::solve(&mut members, &none, ctx.dt, ctx.gravity, &mut scratch);
        self.scratch = scratch;
    }

    fn implicit(&mut self) -> Option<&mut dyn Implicit> {
        Some(self)
    }

    /// Backward Euler has no stability bound: dt is chosen for accuracy.
    fn stable_dt(&self, _phyxels: &Phyxels, _m: &Material) -> f32 {
        f32::INFINITY
    }

    fn displacement_gradient(&self) -> Option<&[Mat3]> {
        self.mls.displacement_gradient()
    }

    /// `mls`'s bound for the same body.
    fn explicit_dt(&self, phyxels: &Phyxels, m: &Material) -> Option<f32> {
        Some(self.mls.stable_dt(phyxels, m))
    }

    fn fragment(&self, phyxels: &Phyxels, material: &Material) -> Option<Box<dyn Dynamics>> {
        Some(Box::new(MlsImplicit::new(phyxels, material)))
    }

    fn can_fracture(&self, material: &Material) -> bool {
        self.mls.can_fracture(material)
    }

    fn wants_new_rest(&self) -> bool {
        self.mls.wants_new_rest()
    }

    /// As `mls`, and the preconditioner is rebuilt for the new rest state.
    fn rest_replaced(&mut self, phyxels: &Phyxels, material: &Material) {
        self.mls.rest_replaced(phyxels, material);
        self.pre = None;
    }

    /// As `mls`, but the elastic energy is that of the current positions (the explicit
    /// backend's last gradient is that of the positions before its step; this one's
    /// would be its last Newton iterate's), and with the solver's figures.
    fn diagnostics(&self, phyxels: &Phyxels, material: &Material) -> Diagnostics {
        let law = Law::new(material, 0.0, 0.0);
        let st = &self.mls.stencil;
        let u = |j: usize| (phyxels.pos.get(j) - phyxels.rest.get(j)) + phyxels.pos_carry.get(j);
        let energy = (0..phyxels.len())
            .map(|i| {
                let g = st.gradient_of(i, u);
                law.energy_density(g, self.mls.plastic.get(i)) as f64 * phyxels.volume[i] as f64
            })
            .sum();
        Diagnostics {
            elastic_energy: Some(energy),
            solver: Some(self.stats),
            ..self.mls.diagnostics(phyxels, material)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use phyxel::body::shape::Shape;

    /// A sphere under a smooth finite deformation (rotation, stretch, shear).
    fn deformed() -> (Phyxels, Material) {
        let mat = Material::default();
        let v = Shape::Sphere { radius: 0.1 }.sample_volume(0.02);
        let mut p = Phyxels::at_rest(&v.positions, v.cell_volume, mat.density);
        let rot = glam::Quat::from_rotation_z(0.3);
        for i in 0..p.len() {
            let x = p.rest.get(i);
            let y = rot * Vec3::new(1.03 * x.x + 0.02 * x.y, 0.99 * x.y, x.z + 0.5 * x.x * x.x);
            p.pos.set(i, y);
        }
        (p, mat)
    }

    /// The matrix-free tangent `K p` against a central difference of the forces
    /// `(f(x − εp) − f(x + εp)) / 2ε` on a deformed sphere, within 2% (the tangent
    /// leaves out `k_v (det J − 1) ∂cof`, small at these strains, and f32 forces limit
    /// the difference's accuracy).
    ///
    /// Also with the fit's residual stabilisation at weight 1 and a rough direction, which
    /// that term resists.
    #[test]
    fn tangent_matches_a_difference_of_forces() {
        let (p, mat) = deformed();
        tangent_against_difference(p.clone(), mat.clone(), false);
        let stabilised = Material {
            stabilisation: 1.0,
            ..mat
        };
        tangent_against_difference(p, stabilised, true);
    }

    fn tangent_against_difference(mut p: Phyxels, mat: Material, rough: bool) {
        let n = p.len();
        let mut imp = MlsImplicit::new(&p, &mat);
        let w: Vec<Vec3> = (0..n)
            .map(|j| {
                let x = p.rest.get(j);
                let h = (j as u32).wrapping_mul(2_654_435_761);
                let c = |s: u32| ((h >> s) & 0xff) as f32 / 127.5 - 1.0;
                let noise = if rough {
                    Vec3::new(c(0), c(8), c(16))
                } else {
                    Vec3::ZERO
                };
                Vec3::new((7.0 * x.y).sin(), (5.0 * x.z).cos(), 3.0 * x.x) + noise
            })
            .collect();
        imp.mls.compute_forces(&p, &mat, 0.0);
        imp.linearise_law(&p, &mat);
        let mut ap = vec![Vec3::ZERO; n];
        imp.tangent(&p, &mat, 1.0, &w, &mut ap);
        let kw: Vec<Vec3> = (0..n).map(|j| ap[j] - w[j] * p.mass[j]).collect();
        let eps = 1e-4;
        let x0: Vec<Vec3> = (0..n).map(|j| p.pos.get(j)).collect();
        let mut force = |sign: f32| {
            for j in 0..n {
                p.pos.set(j, x0[j] + w[j] * (sign * eps));
            }
            imp.mls.compute_forces(&p, &mat, 0.0);
            (0..n).map(|j| imp.mls.internal.get(j)).collect::<Vec<_>>()
        };
        let (plus, minus) = (force(1.0), force(-1.0));
        let fd: Vec<Vec3> = (0..n).map(|j| (minus[j] - plus[j]) / (2.0 * eps)).collect();
        let err: f32 = (0..n)
            .map(|j| (kw[j] - fd[j]).length_squared())
            .sum::<f32>()
            .sqrt();
        let size: f32 = fd.iter().map(|v| v.length_squared()).sum::<f32>().sqrt();
        assert!(err < 0.02 * size, "|Kw − FD| = {err}, |FD| = {size}");
    }
}
