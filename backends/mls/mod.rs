//! MLS elasticity backend (Müller, Keiser, Nealen, Pauly, Gross, Alexa 2004,
//! "Point based animation of elastic, plastic and melting objects").
//!
//! Written only against phyxel's public API, as an outside crate would be.
//!
//! Per phyxel i, with the rest stencil `d_j` of [`MlsStencil`]:
//! `J = I + ∇uᵀ` (our `∇u` is stored with column b = ∂u/∂x_b, so `J = I + G`),
//! strain `ε = ½(JᵀJ − I)` (or the paper's `JᵀJ − I`), plastic part removed,
//! stress `σ = λ tr(ε) I + 2μ ε` plus the Kelvin–Voigt viscous stress `τ C ε̇`,
//! `P_i = −v_i J σ − v_i k_v (det J − 1) cof(J)`; forces `f_j += P_i d_j`, `f_i += P_i d_i`.
//! Since `d_i = −Σ_j d_j`, each phyxel's forces sum to zero: momentum is conserved.

#[cfg(test)]
mod tests;

use glam::{Mat3, Quat, Vec3};
use phyxel::columns::Vec3s;
use phyxel::dynamics::gradient::MlsStencil;
use phyxel::dynamics::stabilisation::Stabilisation;
use phyxel::dynamics::{
    Diagnostics, Dynamics, StepContext, damped_euler_limit, integrate_symplectic,
};
use phyxel::material::{Material, StrainForm};
use phyxel::math::kernel::poly6_shape;
use phyxel::math::linalg::cofactor;
use phyxel::par;
use phyxel::points::phyxels::Phyxels;
use phyxel::spatial::gather::RowBuffer;
use rayon::prelude::*;

pub mod implicit;
mod lanes;
mod law;
pub use implicit::MlsImplicit;
use lanes::{LaneInputs, LaneOutputs, LaneStencil};
use law::{Law, frobenius};

/// The backend's name in scenes and on the command line (`backend = "mls"`).
pub const NAME: &str = "mls";

/// Power iterations for the largest stencil frequency (converges to within a few
/// percent from below; the stable step keeps a margin for that).
const POWER_ITERATIONS: usize = 60;

/// Fraction of the symplectic-Euler limit `2/ω_max` used as the stable bound: covers the
/// power iteration's under-estimate and stiffening at finite strain.
const STABILITY_MARGIN: f32 = 0.8;

/// With `fracture`, the rest configuration is renewed once a phyxel's plastic strain
/// reaches this fraction of `plastic_max` (just below the cap, where flow would stop).
const RENEW_FRACTION: f32 = 0.99;

/// MLS elasticity for one object.
pub struct MlsDynamics {
    stencil: MlsStencil,
    /// `incoming[in_off[j]..in_off[j + 1]]`: (phyxel i, stencil entry k) with j = neighbours[k].
    in_off: Vec<u32>,
    incoming: Vec<(u32, u32)>,
    /// The stencil in lane layout for the SIMD kernel.
    lanes: LaneStencil,
    /// `P` per phyxel for the lane kernel's force pass (kept between steps), and
    /// `[u, v, 0, 0]` per phyxel for its gathers: `gather::RowBuffer`s (65,536 rows
    /// for bodies up to that size within the process's budget, allocated zeroed, so the
    /// rows past the body's are never touched), the length at which the gathers need no
    /// bounds checks.
    stress_rows: RowBuffer<lanes::StressRow>,
    state: RowBuffer<[f32; 8]>,
    /// Displacement gradient per phyxel (column b = ∂u/∂x_b).
    grad: Vec<Mat3>,
    /// `P_i` per phyxel (N per unit `d`), for the scalar reference.
    stress_force: Vec<Mat3>,
    internal: Vec3s,
    /// Per-phyxel gather output, kept between steps (no allocation in the step).
    gathered: Vec<Vec3>,
    /// Displacement and velocity packed per phyxel for the stencil gathers.
    disp: Vec<Vec3>,
    vel: Vec<Vec3>,
    /// Plastic strain per phyxel; empty for elastic materials (no plasticity work).
    plastic: Vec<Mat3>,
    max_strain: f32,
    /// Largest Frobenius norm of the plastic strain at the last force evaluation.
    max_plastic: f32,
    /// Plastic flow asks for a new rest configuration (materials with `fracture`).
    new_rest: bool,
    /// Rest configurations renewed so far.
    rest_updates: u64,
    /// Smallest phyxel spacing (m), for the default damping.
    r_min: f32,
    /// `ω²_max` (1/s²) of the rest stencil with the object's material;
    /// see [`MlsDynamics::stable_dt`].
    omega2_max: f32,
    /// The fit's residual stabilisation (`None` at weight 0).
    stabilisation: Option<Stabilisation>,
}

impl MlsDynamics {
    /// Builds the rest stencil of `phyxels`.
    pub fn new(phyxels: &Phyxels, material: &Material) -> Self {
        let n = phyxels.len();
        let stencil = fracture_stencil(phyxels, material);
        let (in_off, incoming) = incoming_of(&stencil);
        let lanes = LaneStencil::new(&stencil, &in_off, &incoming);
        let stabilisation = stabilisation_of(phyxels, material, &stencil);
        let mut mls = Self {
            stress_rows: RowBuffer::zeroed(lanes.padded()),
            state: RowBuffer::zeroed(lanes.padded()),
            lanes,
            stencil,
            in_off,
            incoming,
            grad: vec![Mat3::ZERO; n],
            stress_force: Vec::new(),
            internal: Vec3s::zeros(n),
            gathered: vec![Vec3::ZERO; n],
            disp: vec![Vec3::ZERO; n],
            vel: Vec::new(),
            plastic: if material.is_plastic() {
                vec![Mat3::ZERO; n]
            } else {
                Vec::new()
            },
            max_strain: 0.0,
            max_plastic: 0.0,
            new_rest: false,
            rest_updates: 0,
            r_min: phyxels.spacing[..n]
                .iter()
                .fold(f32::INFINITY, |a, &b| a.min(b)),
            omega2_max: 0.0,
            stabilisation,
        };
        mls.omega2_max = mls.stiffness_rate(phyxels, material);
        mls
    }

    /// Largest squared angular frequency `ω²_max` (1/s²) of the small-strain
    /// problem `K v = ω² M v`, by power iteration with the
    /// Rayleigh quotient; fixed phyxels are held at zero.
    fn stiffness_rate(&self, phyxels: &Phyxels, material: &Material) -> f32 {
        let n = self.stencil.len();
        let free = |j: usize| phyxels.fixed[j] == 0 && phyxels.mass[j] > 0.0;
        // A deterministic, rough start vector excites the high modes.
        let mut v: Vec<Vec3> = (0..n)
            .map(|j| {
                let h = (j as u32).wrapping_mul(2_654_435_761);
                let c = |s: u32| ((h >> s) & 0xff) as f32 / 127.5 - 1.0;
                if free(j) {
                    Vec3::new(c(0), c(8), c(16))
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        let mut kv = vec![Vec3::ZERO; n];
        let mut stress = vec![Mat3::ZERO; n];
        let mut rate = 0.0f32;
        for _ in 0..POWER_ITERATIONS {
            self.apply_stiffness(phyxels, material, &v, &mut stress, &mut kv);
            let (mut vkv, mut vmv) = (0.0f64, 0.0f64);
            for j in 0..n {
                vkv += v[j].dot(kv[j]) as f64;
                vmv += (phyxels.mass[j] * v[j].length_squared()) as f64;
            }
            if vmv <= 0.0 {
                break;
            }
            rate = rate.max((vkv / vmv) as f32);
            let mut norm = 0.0f32;
            for j in 0..n {
                v[j] = if free(j) {
                    kv[j] / phyxels.mass[j]
                } else {
                    Vec3::ZERO
                };
                norm = norm.max(v[j].abs().max_element());
            }
            if norm <= 0.0 {
                break;
            }
            v.iter_mut().for_each(|x| *x /= norm);
        }
        rate
    }

    /// `K v`: the stiffness of the material's law linearised about the rest state
    /// (`σ = s(λ tr ε I + 2μ ε) + k_v tr ε I`, s = 4 for the paper's strain form).
    ///
    /// In parallel: `P_i` per phyxel, then `(K v)_j` gathered per phyxel over the rows
    /// that name j. Each sum runs over the rows in increasing order with the own term
    /// at its row's place, the order of a serial scatter over the rows, so the result
    /// (and the stable dt built on it) does not depend on the thread count.
    fn apply_stiffness(
        &self,
        phyxels: &Phyxels,
        material: &Material,
        v: &[Vec3],
        stress: &mut [Mat3],
        out: &mut [Vec3],
    ) {
        let st = &self.stencil;
        let (lambda, mu) = material.lame();
        let s = if material.strain == StrainForm::Paper {
            4.0
        } else {
            1.0
        };
        let kv = material.k_volume();
        // Small bodies in one task: 120 parallel calls per body (the power iteration)
        // cost more to dispatch than to compute (5,000 small spheres: seconds).
        let min_len = par::point_task();
        stress
            .par_iter_mut()
            .with_min_len(min_len)
            .enumerate()
            .for_each(|(i, p)| {
                let g = st.gradient_of(i, |j| v[j]);
                let e = (g + g.transpose()) * 0.5;
                let tr = e.x_axis.x + e.y_axis.y + e.z_axis.z;
                let sigma = Mat3::from_diagonal(Vec3::splat(s * lambda * tr + kv * tr))
                    + e * (2.0 * s * mu);
                *p = sigma * phyxels.volume[i];
            });
        let (in_off, incoming) = (&self.in_off, &self.incoming);
        out.par_iter_mut()
            .with_min_len(min_len)
            .enumerate()
            .for_each(|(j, o)| {
                let own = stress[j] * st.d_self[j];
                let mut sum = Vec3::ZERO;
                let mut own_added = false;
                for &(i, k) in &incoming[in_off[j] as usize..in_off[j + 1] as usize] {
                    if !own_added && i as usize > j {
                        sum += own;
                        own_added = true;
                    }
                    sum += stress[i as usize] * st.d[k as usize];
                }
                if !own_added {
                    sum += own;
                }
                *o = sum;
            });
        if let Some(k) = &self.stabilisation {
            k.add_product(|l| v[l], 1.0, out);
        }
    }

    /// The rest stencil (for diagnostics and tests).
    pub fn stencil(&self) -> &MlsStencil {
        &self.stencil
    }

    /// Number of phyxels whose moment matrix was ill-conditioned.
    pub fn ill_conditioned(&self) -> usize {
        self.stencil.ill_conditioned.iter().filter(|&&b| b).count()
    }

    /// Plastic strain per phyxel (empty for elastic materials).
    pub fn plastic_strain(&self) -> &[Mat3] {
        &self.plastic
    }

    /// Internal elastic forces of the current state, in `self.internal` (N), by the lane
    /// kernel (eight phyxels per `f32x8`, see `lanes`). `dt` only matters for plastic flow.
    pub fn compute_forces(&mut self, phyxels: &Phyxels, material: &Material, dt: f32) {
        let law = Law::new(material, dt, self.tau(material));
        // The buffers were sized in `new` (`gather::RowBuffer`); the phyxel count, and so
        // `padded`, never changes for a backend.
        let padded = self.lanes.padded();
        let vel = (law.tau > 0.0).then_some(&phyxels.vel);
        let p = phyxels;
        lanes::pack_state(
            &p.pos,
            &p.rest,
            &p.pos_carry,
            vel,
            &mut self.state[..padded],
        );
        let input = LaneInputs {
            law,
            state: &self.state,
            volume: &phyxels.volume,
        };
        let out = LaneOutputs {
            grad: &mut self.grad,
            plastic: &mut self.plastic,
            stress: &mut self.stress_rows[..padded],
        };
        self.max_strain = lanes::stress_pass(&self.lanes, &input, out);
        self.after_plastic_flow(material);
        let f = &mut self.internal;
        lanes::force_pass(&self.lanes, &self.stress_rows, &mut f.x, &mut f.y, &mut f.z);
        if let Some(k) = &self.stabilisation {
            let state = &self.state;
            add_stabilisation(k, |l| Vec3::from_slice(&state[l][..3]), f);
        }
    }

    /// Displacement (and, with viscosity, velocity) packed per phyxel for the stencil
    /// gathers; returns the law of this step.
    fn pack_state(&mut self, phyxels: &Phyxels, material: &Material, dt: f32) -> Law {
        let n = self.stencil.len();
        self.disp.resize(n, Vec3::ZERO);
        self.disp
            .par_iter_mut()
            .with_min_len(par::point_task())
            .enumerate()
            // As `lanes::pack_state`: exact `pos − rest`, plus the position sum's carry.
            .for_each(|(i, u)| {
                *u = (phyxels.pos.get(i) - phyxels.rest.get(i)) + phyxels.pos_carry.get(i)
            });
        let law = Law::new(material, dt, self.tau(material));
        if law.tau > 0.0 {
            self.vel.resize(n, Vec3::ZERO);
            self.vel
                .par_iter_mut()
                .with_min_len(par::point_task())
                .enumerate()
                .for_each(|(i, v)| *v = phyxels.vel.get(i));
        }
        law
    }

    /// With `fracture`, asks for a new rest configuration once plastic flow reaches
    /// the cap.
    fn after_plastic_flow(&mut self, material: &Material) {
        if !self.plastic.is_empty() && material.fracture {
            self.max_plastic = self
                .plastic
                .par_iter()
                .with_min_len(par::point_task())
                .map(|&ep| frobenius(ep))
                .reduce(|| 0.0, f32::max);
            // Flow has reached the cap: renew the rest state so that it can go on.
            self.new_rest = self.max_plastic >= RENEW_FRACTION * material.plastic_max;
        }
    }

    /// The scalar reference of [`MlsDynamics::compute_forces`]: per phyxel, glam
    /// matrices, the stencil in rows and the transposed lists (same formulas and sum
    /// order; the results agree to rounding, see `tests/dynamics/mls.rs`).
    #[doc(hidden)]
    pub fn compute_forces_reference(&mut self, phyxels: &Phyxels, material: &Material, dt: f32) {
        let law = self.pack_state(phyxels, material, dt);
        let st = &self.stencil;
        let n = st.len();
        st.gradients(&self.disp, &mut self.grad);
        self.stress_force.resize(n, Mat3::ZERO);
        let grad = &self.grad;
        let vel = &self.vel;
        let volume = &phyxels.volume;
        let stress_at = |i: usize, plastic: Option<&mut Mat3>| {
            let strain_rate_grad = if law.tau > 0.0 {
                Some(st.gradient_of(i, |j| vel[j]))
            } else {
                None
            };
            law.stress_force(grad[i], strain_rate_grad, plastic, volume[i])
        };
        let max_strain = if self.plastic.is_empty() {
            self.stress_force
                .par_iter_mut()
                .enumerate()
                .map(|(i, p)| {
                    let (pf, e) = stress_at(i, None);
                    *p = pf;
                    e
                })
                .reduce(|| 0.0, f32::max)
        } else {
            self.stress_force
                .par_iter_mut()
                .zip(self.plastic.par_iter_mut())
                .enumerate()
                .map(|(i, (p, ep))| {
                    let (pf, e) = stress_at(i, Some(ep));
                    *p = pf;
                    e
                })
                .reduce(|| 0.0, f32::max)
        };
        self.max_strain = max_strain;
        self.after_plastic_flow(material);
        self.gather_forces();
        if let Some(k) = &self.stabilisation {
            let disp = &self.disp;
            add_stabilisation(k, |l| disp[l], &mut self.internal);
        }
    }

    /// `f_j = P_j d_j(self) + Σ_{i: j ∈ N(i)} P_i d_ij`, gathered per phyxel so the
    /// parallel loop writes disjoint entries and the sum order is fixed (deterministic).
    fn gather_forces(&mut self) {
        let st = &self.stencil;
        let pf = &self.stress_force;
        let (in_off, incoming) = (&self.in_off, &self.incoming);
        self.gathered
            .par_iter_mut()
            .with_min_len(par::point_task())
            .enumerate()
            .for_each(|(j, f)| {
                *f = pf[j] * st.d_self[j];
                for &(i, k) in &incoming[in_off[j] as usize..in_off[j + 1] as usize] {
                    *f += pf[i as usize] * st.d[k as usize];
                }
            });
        self.internal.par_set_from(&self.gathered, |&f| f);
    }

    /// Stress `σ = C(ε − ε_p)` of phyxel i at the last force evaluation (Pa).
    pub fn stress(&self, material: &Material, i: usize) -> Mat3 {
        let law = Law::new(material, 0.0, 0.0);
        let mut e = law.strain(self.grad[i]);
        if let Some(ep) = self.plastic.get(i) {
            e -= *ep;
        }
        law.hooke(e)
    }

    /// Wave speed (m/s) of the material in this backend's strain form.
    fn wave_speed(material: &Material) -> f32 {
        let stiff = if material.strain == StrainForm::Paper {
            4.0
        } else {
            1.0
        };
        let (lambda, mu) = material.lame();
        ((stiff * (lambda + 2.0 * mu) + material.k_volume()) / material.density).sqrt()
    }

    /// Kelvin–Voigt time τ (s) in effect.
    pub fn tau(&self, material: &Material) -> f32 {
        material.damping_time(self.r_min, Self::wave_speed(material))
    }

    /// Rest configurations renewed by plastic flow so far (`fracture` materials only).
    pub fn rest_updates(&self) -> u64 {
        self.rest_updates
    }

    /// Internal forces of the last step (N).
    pub fn internal_forces(&self) -> &Vec3s {
        &self.internal
    }
}

/// Largest ratio of the spacings within a phyxel's stencil that still counts as one
/// level: graded levels lie 2× apart, while a uniform lattice's spacings (each phyxel's
/// mean distance to its nearest) differ by at most 1.3× between a corner and the inside.
const LEVEL_SPREAD: f32 = 1.5;

/// The fit's residual stabilisation of `phyxels`, with the law's small-strain shear
/// modulus: at the material's weight on every phyxel, or by default at weight 1 on the
/// phyxels whose stencil spans two levels of a graded cloud (spacings over
/// [`LEVEL_SPREAD`] apart), where the one-sided stencils couple nodal integration's
/// spurious modes to smooth loads. `None` where no phyxel takes it.
fn stabilisation_of(
    phyxels: &Phyxels,
    material: &Material,
    stencil: &MlsStencil,
) -> Option<Stabilisation> {
    let spacing = &phyxels.spacing;
    let interface = |i: usize| {
        let (lo, hi) = stencil.neighbours[stencil.row(i)]
            .iter()
            .map(|&j| spacing[j as usize])
            .fold((spacing[i], spacing[i]), |(lo, hi), s| {
                (lo.min(s), hi.max(s))
            });
        hi > LEVEL_SPREAD * lo
    };
    let alpha = |i: usize| match material.stabilisation {
        a if a >= 0.0 => a as f64,
        _ if interface(i) => 1.0,
        _ => 0.0,
    };
    if (0..stencil.len()).all(|i| alpha(i) == 0.0) {
        return None;
    }
    let scale = if material.strain == StrainForm::Paper {
        4.0
    } else {
        1.0
    };
    Some(Stabilisation::build(
        phyxels,
        stencil,
        (scale * material.lame().1) as f64,
        alpha,
    ))
}

/// `f −= K u`: the stabilisation's forces added to the internal forces.
fn add_stabilisation(k: &Stabilisation, u: impl Fn(usize) -> Vec3 + Sync, f: &mut Vec3s) {
    let n = k.len();
    f.x[..n]
        .par_iter_mut()
        .zip(f.y[..n].par_iter_mut())
        .zip(f.z[..n].par_iter_mut())
        .with_min_len(par::point_task())
        .enumerate()
        .for_each(|(j, ((x, y), z))| {
            let p = k.product_at(j, &u);
            *x -= p.x;
            *y -= p.y;
            *z -= p.z;
        });
}

/// Smallest isotropy `det A / (tr A / 3)³` of a moment matrix whose row is kept in a
/// body that may break (1 for an isotropic neighbourhood, 0 for a flat or linear one).
const MIN_ISOTROPY: f32 = 0.02;

/// The rest stencil; for materials that may break, rows whose neighbourhood is
/// (nearly) flat, linear or empty are emptied. Such rows appear in torn, stretched
/// configurations and in small fragments; their weights `d_j` grow like the inverse of
/// the smallest moment eigenvalue, and so would the highest frequency of the body (an
/// explicit step that was stable would blow up). An emptied row exerts no stress of its
/// own; the phyxel still takes part in its neighbours' rows.
fn fracture_stencil(phyxels: &Phyxels, material: &Material) -> MlsStencil {
    let mut st = MlsStencil::build_with(phyxels, material.gradient);
    if !material.fracture {
        return st;
    }
    for i in 0..st.len() {
        let xi = phyxels.rest.get(i);
        let h = phyxels.radius[i];
        let mut a = Mat3::ZERO;
        for k in st.row(i) {
            let x = phyxels.rest.get(st.neighbours[k] as usize) - xi;
            // Unnormalised, as in the stencil: the isotropy is a ratio.
            let w = poly6_shape(x.length_squared(), h);
            a += Mat3::from_cols(x * (x.x * w), x * (x.y * w), x * (x.z * w));
        }
        let tr = (a.x_axis.x + a.y_axis.y + a.z_axis.z) / 3.0;
        let isotropy = if tr > 0.0 {
            a.determinant() / (tr * tr * tr)
        } else {
            0.0
        };
        if st.ill_conditioned[i] || isotropy.is_nan() || isotropy < MIN_ISOTROPY {
            for k in st.row(i) {
                st.d[k] = Vec3::ZERO;
            }
            st.d_self[i] = Vec3::ZERO;
        }
    }
    st
}

/// For every phyxel j, the stencil entries (i, k) that name it: the transpose of the
/// stencil, so forces can be gathered per phyxel.
fn incoming_of(stencil: &MlsStencil) -> (Vec<u32>, Vec<(u32, u32)>) {
    let n = stencil.len();
    let mut count = vec![0u32; n + 1];
    for &j in &stencil.neighbours {
        count[j as usize + 1] += 1;
    }
    for j in 0..n {
        count[j + 1] += count[j];
    }
    let in_off = count.clone();
    let mut incoming = vec![(0u32, 0u32); stencil.neighbours.len()];
    for i in 0..n {
        for k in stencil.row(i) {
            let j = stencil.neighbours[k] as usize;
            incoming[count[j] as usize] = (i as u32, k as u32);
            count[j] += 1;
        }
    }
    (in_off, incoming)
}

impl Dynamics for MlsDynamics {
    fn name(&self) -> &str {
        NAME
    }

    fn step(&mut self, phyxels: &mut Phyxels, ctx: &StepContext<'_>) {
        self.compute_forces(phyxels, ctx.material, ctx.dt);
        integrate_symplectic(phyxels, &self.internal, ctx);
    }

    /// `margin · 2/ω_max · (√(1 + ζ²) − ζ)`: the symplectic-Euler limit of the fastest
    /// mode with Kelvin–Voigt damping ratio `ζ = τ ω_max / 2`, `ω_max` measured on the
    /// rest stencil by power iteration.
    fn stable_dt(&self, _phyxels: &Phyxels, m: &Material) -> f32 {
        let omega = self.omega2_max.sqrt();
        if omega <= 0.0 {
            return f32::INFINITY;
        }
        let zeta = 0.5 * self.tau(m) * omega;
        STABILITY_MARGIN * damped_euler_limit(omega, zeta)
    }

    fn displacement_gradient(&self) -> Option<&[Mat3]> {
        Some(&self.grad)
    }

    /// Materials with `fracture = true` (see [`Material::fracture`]).
    fn fragment(&self, phyxels: &Phyxels, material: &Material) -> Option<Box<dyn Dynamics>> {
        Some(Box::new(MlsDynamics::new(phyxels, material)))
    }

    fn can_fracture(&self, material: &Material) -> bool {
        material.fracture
    }

    fn wants_new_rest(&self) -> bool {
        self.new_rest
    }

    /// Plastic flow with time-varying connectivity (Desbrun & Cani 1996; Müller et al.
    /// 2004 §4.4 keep the stencil fixed): the current shape becomes the rest shape, the
    /// stencil is rebuilt from the neighbours within the influence radius there (phyxels
    /// that drifted apart lose their bond), and the plastic strain becomes
    /// `ε_p − ε`, so the elastic strain `ε − ε_p` (hence the stress) carries over
    /// (additive small-strain split; ε from the last force evaluation).
    fn rest_replaced(&mut self, phyxels: &Phyxels, material: &Material) {
        let law = Law::new(material, 0.0, 0.0);
        for (ep, g) in self.plastic.iter_mut().zip(&self.grad) {
            *ep -= law.strain(*g);
            let norm = frobenius(*ep);
            if norm > material.plastic_max {
                *ep *= material.plastic_max / norm;
            }
        }
        self.stencil = fracture_stencil(phyxels, material);
        let (in_off, incoming) = incoming_of(&self.stencil);
        self.lanes = LaneStencil::new(&self.stencil, &in_off, &incoming);
        self.in_off = in_off;
        self.incoming = incoming;
        self.grad.iter_mut().for_each(|g| *g = Mat3::ZERO);
        self.stabilisation = stabilisation_of(phyxels, material, &self.stencil);
        self.new_rest = false;
        self.rest_updates += 1;
        // The new stencil has its own highest frequency (a torn or compressed rest
        // shape can be much stiffer): the stable bound must follow it.
        self.omega2_max = self.stiffness_rate(phyxels, material);
    }

    fn diagnostics(&self, phyxels: &Phyxels, material: &Material) -> Diagnostics {
        let law = Law::new(material, 0.0, 0.0);
        let energy = (0..phyxels.len())
            .map(|i| {
                law.energy_density(self.grad[i], self.plastic.get(i)) as f64
                    * phyxels.volume[i] as f64
            })
            .sum::<f64>()
            + self.stabilisation.as_ref().map_or(0.0, |k| {
                k.energy(|l| (phyxels.pos.get(l) - phyxels.rest.get(l)) + phyxels.pos_carry.get(l))
            });
        Diagnostics {
            elastic_energy: Some(energy),
            max_strain: Some(self.max_strain),
            max_plastic_strain: (!self.plastic.is_empty()).then(|| {
                self.plastic
                    .iter()
                    .map(|&ep| frobenius(ep))
                    .fold(0.0, f32::max)
            }),
            flat_phyxels: Some(self.ill_conditioned()),
            solver: None,
        }
    }
}
