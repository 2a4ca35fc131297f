//! The constitutive law of the MLS backend: strain from the deformation gradient, Hooke's
//! stress with Kelvin–Voigt damping and plastic strain, the force it puts on a phyxel's
//! stencil, and the energy density.

use super::*;

/// The constitutive law of a material, resolved once per step.
#[derive(Clone, Copy)]
pub(super) struct Law {
    pub(super) lambda: f32,
    pub(super) mu: f32,
    pub(super) kv: f32,
    pub(super) tau: f32,
    pub(super) paper: bool,
    pub(super) plastic_yield: f32,
    /// The fraction of the elastic strain that flows in one step: `1 − exp(−c·dt)`,
    /// the exact step of the creep law `ε̇_p = c (ε − ε_p)` at the step's strain. It is
    /// `c·dt` to first order and never exceeds 1, so a fast creep (or a large dt) cannot
    /// carry `ε_p` past `ε` and flip the stress (the explicit `c·dt` gives a free-falling
    /// body 250 J of elastic energy at `c = 10⁴`/s).
    pub(super) plastic_creep_dt: f32,
    pub(super) plastic_max: f32,
}

impl Law {
    pub(super) fn new(m: &Material, dt: f32, tau: f32) -> Self {
        let (lambda, mu) = m.lame();
        Self {
            lambda,
            mu,
            kv: m.k_volume(),
            tau,
            paper: m.strain == StrainForm::Paper,
            plastic_yield: m.plastic_yield,
            plastic_creep_dt: -(-m.plastic_creep * dt).exp_m1(),
            plastic_max: m.plastic_max,
        }
    }

    /// Isotropic Hooke law `σ = λ tr(ε) I + 2μ ε`.
    #[inline]
    pub(super) fn hooke(&self, e: Mat3) -> Mat3 {
        let tr = e.x_axis.x + e.y_axis.y + e.z_axis.z;
        Mat3::from_diagonal(Vec3::splat(self.lambda * tr)) + e * (2.0 * self.mu)
    }

    /// Strain of the displacement gradient `g` (`J = I + g`; calibrated or paper form),
    /// as `g + gᵀ + gᵀg`: the same as `JᵀJ − I`, without forming `J`, whose f32
    /// entries near 1 keep only 1e-7 of the strain (10 Pa of stress noise at E = 1e8,
    /// which a stiff bar's stencil sums amplify into force noise a fifth of its weight).
    #[inline]
    pub(super) fn strain(&self, g: Mat3) -> Mat3 {
        let c = g + g.transpose() + g.transpose() * g;
        if self.paper { c } else { c * 0.5 }
    }

    /// The change of the strain measure when `J` changes by `dj`: `½(dJᵀJ + JᵀdJ)`
    /// (twice that for the paper form); with `dj = J̇` it is the strain rate.
    #[inline]
    pub(super) fn strain_rate(&self, j: Mat3, dj: Mat3) -> Mat3 {
        let rate = j.transpose() * dj + dj.transpose() * j;
        if self.paper { rate } else { rate * 0.5 }
    }

    /// `P = −v (s J σ + k_v (det J − 1) cof J)` and the strain norm, updating plastic strain.
    #[inline]
    pub(super) fn stress_force(
        &self,
        grad: Mat3,
        vel_grad: Option<Mat3>,
        plastic: Option<&mut Mat3>,
        volume: f32,
    ) -> (Mat3, f32) {
        let j = Mat3::IDENTITY + grad;
        let strain = self.strain(grad);
        let mut elastic = strain;
        if let Some(ep) = plastic {
            let e = strain - *ep;
            if frobenius(e) > self.plastic_yield {
                *ep += e * self.plastic_creep_dt;
            }
            let norm = frobenius(*ep);
            if norm > self.plastic_max {
                *ep *= self.plastic_max / norm;
            }
            elastic = strain - *ep;
        }
        let mut sigma = self.hooke(elastic);
        if let Some(jd) = vel_grad {
            // ε̇ of the strain measure: ½(JᵀJ̇ + J̇ᵀJ) (twice that for the paper form).
            sigma += self.hooke(self.strain_rate(j, jd)) * self.tau;
        }
        let s = if self.paper { 2.0 } else { 1.0 };
        let mut p = j * sigma * (-volume * s);
        if self.kv > 0.0 {
            let cof = cofactor(j);
            p -= cof * (volume * self.kv * det_minus_one(grad));
        }
        (p, frobenius(strain))
    }

    /// Elastic energy density ½ ε:σ + ½ k_v (det J − 1)² (J/m³); its derivative with
    /// respect to J is the P of [`Law::stress_force`] in either strain form.
    pub(super) fn energy_density(&self, grad: Mat3, plastic: Option<&Mat3>) -> f32 {
        let mut e = self.strain(grad);
        if let Some(ep) = plastic {
            e -= *ep;
        }
        let sigma = self.hooke(e);
        let dot = (0..3).map(|c| e.col(c).dot(sigma.col(c))).sum::<f32>();
        let dv = det_minus_one(grad);
        0.5 * dot + 0.5 * self.kv * dv * dv
    }
}

/// `det(I + g) − 1 = tr g + I₂(g) + det g` (I₂: the sum of the principal 2×2 minors),
/// without the cancellation of `det J − 1` in f32.
#[inline]
pub(super) fn det_minus_one(g: Mat3) -> f32 {
    let a = |r: usize, c: usize| g.col(c)[r];
    let tr = a(0, 0) + a(1, 1) + a(2, 2);
    let i2 = (a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0))
        + (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1))
        + (a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0));
    tr + i2 + g.determinant()
}

#[inline]
pub(super) fn frobenius(m: Mat3) -> f32 {
    (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt()
}
