//! Material parameters of an object (SI units).

use serde::{Deserialize, Serialize};

/// Which strain measure the MLS elasticity uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StrainForm {
    /// Green–Saint-Venant strain `½(JᵀJ − I)` with `f = −v J σ d`: small-strain stiffness E.
    #[default]
    Calibrated,
    /// The paper's `JᵀJ − I` with `f = −2 v J σ d`: four times stiffer at small strain;
    /// kept to compare with Müller et al. 2004.
    Paper,
}

/// Material of an object. Defaults describe a soft rubber-like solid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Material {
    /// Rest density ρ (kg/m³).
    pub density: f32,
    /// Young's modulus E (Pa). Also the contact-surface weight λ (paper section 6).
    pub young: f32,
    /// Poisson ratio ν (dimensionless, in (−1, 0.5)).
    pub poisson: f32,
    /// Kelvin–Voigt retardation time τ (s): viscous stress `τ · C ε̇` damps deformation
    /// but not rigid motion. Negative (the default) means the backend's resolution-scaled
    /// damping `τ = DEFAULT_DAMPING_RATIO · r / c`: a damping ratio of 0.1 on the
    /// fastest resolved mode, which stops round-off noise from accumulating and leaves
    /// the body's low modes (bouncing, bending) practically undamped.
    pub damping: f32,
    /// Volume-conservation stiffness k_v (Pa), Müller et al. 2004 eq. (11);
    /// suppresses zero-energy modes and inversion. Negative means "use 0.1 E".
    pub volume_stiffness: f32,
    /// Plastic yield: Frobenius norm of the elastic strain above which plastic flow starts.
    /// Infinite (the default) means purely elastic.
    pub plastic_yield: f32,
    /// Plastic creep rate (1/s).
    pub plastic_creep: f32,
    /// Largest Frobenius norm of the plastic strain. With `fracture = true` it is instead
    /// the plastic strain at which the rest configuration is renewed (plastic flow without
    /// bound, see [`Material::fracture`]).
    pub plastic_max: f32,
    /// The body may break apart (the topology phase splits it into separate objects when
    /// its phyxels fall into groups farther than the influence radius from each other).
    /// With plastic flow (finite `plastic_yield`, `plastic_creep > 0`), the MLS backend
    /// also renews its rest configuration whenever a phyxel's plastic strain reaches
    /// `plastic_max` (rest ← current, connectivity rebuilt within the influence radius),
    /// so a plastic body can neck and tear. An elastic body with `fracture = true` keeps
    /// its rest stencil and splits only if stretched apart beyond the influence radius.
    pub fracture: bool,
    /// Coulomb friction coefficient μ (a pair uses the geometric mean of its two).
    pub friction: f32,
    /// Penalty spring stiffness per contact area in units of `E*/h` (E*: the pair's
    /// Hertz modulus, h: phyxel spacing); a pair uses the mean of its two.
    pub contact_stiffness: f32,
    /// Penalty damping as a fraction of the critical damping of a surface layer one
    /// phyxel spacing thick; a pair uses the mean of its two.
    pub contact_damping: f32,
    /// Strain measure of the MLS elasticity.
    pub strain: StrainForm,
    /// Basis of the MLS gradient fit (a method option of the MLS backend).
    pub gradient: GradientBasis,
    /// Weight α of the MLS fit's residual stabilisation, in units of the shear modulus
    /// (`dynamics::stabilisation`: a residual `r` a distance `x` away costs as much as a
    /// shear strain `r/x`). Negative (the default) means 1 on the phyxels whose stencil
    /// spans two levels of graded sampling, where the one-sided stencils couple nodal
    /// integration's spurious modes to bending, and 0 elsewhere (method option of the
    /// MLS backends).
    pub stabilisation: f32,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            density: 1000.0,
            young: 1.0e5,
            poisson: 0.3,
            damping: -1.0,
            volume_stiffness: -1.0,
            plastic_yield: f32::INFINITY,
            plastic_creep: 0.0,
            plastic_max: 0.0,
            fracture: false,
            friction: 0.0,
            contact_stiffness: 4.0,
            contact_damping: 0.2,
            strain: StrainForm::Calibrated,
            gradient: GradientBasis::Quadratic,
            stabilisation: -1.0,
        }
    }
}

/// Damping ratio of the fastest resolved mode under the default damping.
pub const DEFAULT_DAMPING_RATIO: f32 = 0.1;

/// Largest Young's modulus (Pa) a material may have: a thousand times diamond's. The
/// backends' stiffness bounds square it with the inverse spacing, which overflows f32
/// at 1e37 Pa (the bound is then infinite and the run goes NaN at its third step).
pub const MAX_YOUNG: f32 = 1e15;

/// Range of densities (kg/m³) a material may have: from a millionth of air's to ten
/// thousand times osmium's. Two spheres colliding at 1 m/s stay finite on every backend
/// at its corners, with `young` from 1e-30 to [`MAX_YOUNG`]; `sph` goes NaN in its first
/// step at 1e25, and at 1e-30 with `young = 1e-30` (products under- and overflowing f32).
pub const DENSITY_RANGE: (f32, f32) = (1e-6, 1e10);

/// Largest stabilisation weight accepted: at 100 the term is a hundred times the shear
/// stiffness on the residual, which only shrinks the stable step.
pub const MAX_STABILISATION: f32 = 100.0;

/// Largest Coulomb coefficient accepted. Measured coefficients of dry contacts lie well
/// below it (rubber on rough surfaces about 1–2). The bound was set by a viscous
/// friction law that an oblique impact of two spheres at the default step drove to
/// gain energy from μ = 30 on; the stick springs that replaced it (`contact::stick`)
/// are no stiffer than the normal contact whatever μ, and the bound stays as a
/// plausibility check of the input.
pub const MAX_FRICTION: f32 = 10.0;

/// Smallest `plastic_max` of a plastic material: the plastic strain is capped there, so
/// 0 would mean no flow at all, and strains below about 10⁻⁶ are round-off in f32 (the
/// cap's norm of squares underflows below 10⁻¹⁹, and flow is then unbounded).
pub const MIN_PLASTIC_MAX: f32 = 1e-6;

impl Material {
    /// Kelvin–Voigt time τ (s) for a body of smallest phyxel spacing `r` (m) and wave
    /// speed `c` (m/s): the scene's value, or the resolution-scaled default.
    pub fn damping_time(&self, r: f32, c: f32) -> f32 {
        if self.damping >= 0.0 {
            self.damping
        } else {
            DEFAULT_DAMPING_RATIO * r / c
        }
    }

    /// P-wave speed `√((λ + 2μ)/ρ)` (m/s) of the small-strain law.
    pub fn wave_speed(&self) -> f32 {
        let (lambda, mu) = self.lame();
        ((lambda + 2.0 * mu) / self.density).sqrt()
    }

    /// Lamé parameters (λ, μ) of the isotropic Hooke law (Pa).
    pub fn lame(&self) -> (f32, f32) {
        let (e, nu) = (self.young, self.poisson);
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = e / (2.0 * (1.0 + nu));
        (lambda, mu)
    }

    /// Effective volume stiffness k_v (Pa).
    pub fn k_volume(&self) -> f32 {
        if self.volume_stiffness < 0.0 {
            0.1 * self.young
        } else {
            self.volume_stiffness
        }
    }

    /// True when the material can flow plastically.
    pub fn is_plastic(&self) -> bool {
        self.plastic_yield.is_finite() && self.plastic_creep > 0.0
    }

    /// Turns plastic flow off: an infinite yield stress, and the creep rate and strain
    /// limit at 0 (which [`Material::plastic_keys_used`] requires of an elastic material).
    pub fn make_elastic(&mut self) {
        self.plastic_yield = f32::INFINITY;
        self.plastic_creep = 0.0;
        self.plastic_max = 0.0;
    }

    /// For scenes (`Scene::validate`, which `Scene::build` runs too): plastic parameters
    /// given to an elastic material (infinite `plastic_yield`) do nothing, which is a
    /// mistake. Code that turns a plastic material elastic uses
    /// [`Material::make_elastic`].
    pub fn plastic_keys_used(&self) -> Result<(), String> {
        if self.plastic_yield.is_finite() {
            if self.plastic_creep == 0.0 {
                return Err(format!(
                    "plastic_yield = {} with plastic_creep = 0: no plastic flow (give \
                     plastic_creep > 0, or leave plastic_yield out for an elastic material)",
                    self.plastic_yield
                ));
            }
            return Ok(());
        }
        let given = [
            ("plastic_creep", self.plastic_creep),
            ("plastic_max", self.plastic_max),
        ];
        match given.iter().find(|(_, v)| *v != 0.0) {
            Some((name, v)) => Err(format!(
                "{name} = {v}: has no effect without a finite plastic_yield \
                 (the material is elastic)"
            )),
            None => Ok(()),
        }
    }

    /// Checks every field; the error names the field and the value.
    pub fn validate(&self) -> Result<(), String> {
        let positive = |name: &str, v: f32| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} = {v}: must be a finite number > 0"))
            }
        };
        let non_negative = |name: &str, v: f32| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{name} = {v}: must be a finite number >= 0"))
            }
        };
        positive("density", self.density)?;
        let (lo, hi) = DENSITY_RANGE;
        if !(lo..=hi).contains(&self.density) {
            return Err(format!(
                "density = {:e}: must lie between {lo:e} and {hi:e} kg/m³ (beyond, the \
                 backends' products leave f32's range)",
                self.density
            ));
        }
        positive("young", self.young)?;
        if self.young > MAX_YOUNG {
            return Err(format!(
                "young = {}: must be at most {MAX_YOUNG:e} Pa (a thousand times diamond's; \
                 above it the stiffness bound overflows f32)",
                self.young
            ));
        }
        if !(self.poisson > -1.0 && self.poisson < 0.5) {
            // A value written just inside the range can round onto its end in f32.
            let rounded = if self.poisson == 0.5 || self.poisson == -1.0 {
                " (as an f32: a value written within about 3e-8 of the range's end rounds \
                 onto it; e.g. 0.4999999 stays below 0.5)"
            } else {
                ""
            };
            return Err(format!(
                "poisson = {}{rounded}: must lie strictly between -1 and 0.5",
                self.poisson
            ));
        }
        if !self.damping.is_finite() {
            return Err(format!(
                "damping = {}: must be finite (negative means the default)",
                self.damping
            ));
        }
        if !self.volume_stiffness.is_finite() {
            return Err(format!(
                "volume_stiffness = {}: must be finite (negative means 0.1 * young)",
                self.volume_stiffness
            ));
        }
        // A stiffness like `young`, bounded for the same reason (at 1e37 Pa the stable
        // bound overflows to infinity and the run goes NaN).
        if self.volume_stiffness > MAX_YOUNG {
            return Err(format!(
                "volume_stiffness = {:e}: must be at most {MAX_YOUNG:e} Pa (as young; above it \
                 the stiffness bound overflows f32)",
                self.volume_stiffness
            ));
        }
        if self.plastic_yield.is_nan() || self.plastic_yield < 0.0 {
            return Err(format!(
                "plastic_yield = {}: must be >= 0 (inf for elastic)",
                self.plastic_yield
            ));
        }
        non_negative("plastic_creep", self.plastic_creep)?;
        non_negative("plastic_max", self.plastic_max)?;
        if self.fracture && self.is_plastic() && self.plastic_max <= 0.0 {
            return Err(format!(
                "fracture = true with plastic flow needs plastic_max > 0 (the plastic strain \
                 at which the rest configuration is renewed), got plastic_max = {}",
                self.plastic_max
            ));
        }
        if self.is_plastic() && self.plastic_max < MIN_PLASTIC_MAX {
            return Err(format!(
                "plastic_max = {:e}: plastic flow needs plastic_max >= {MIN_PLASTIC_MAX:e} (the \
                 largest plastic strain; at 0 nothing flows, and strains this small are below \
                 what f32 resolves)",
                self.plastic_max
            ));
        }
        non_negative("friction", self.friction)?;
        if self.friction > MAX_FRICTION {
            return Err(format!(
                "friction = {}: must be at most {MAX_FRICTION} (dry contacts lie below 2)",
                self.friction
            ));
        }
        positive("contact_stiffness", self.contact_stiffness)?;
        non_negative("contact_damping", self.contact_damping)?;
        if self.stabilisation.is_nan() || self.stabilisation > MAX_STABILISATION {
            return Err(format!(
                "stabilisation = {}: must be at most {MAX_STABILISATION} (negative means the \
                 default: 1 where graded levels meet, 0 elsewhere)",
                self.stabilisation
            ));
        }
        Ok(())
    }
}

/// Polynomial basis of the MLS fit behind the gradient.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GradientBasis {
    /// Linear basis (Müller et al. 2004): exact for affine fields; near a free surface the
    /// one-sided neighbourhood biases the gradient of curved fields (bending comes out soft).
    Linear,
    /// Linear plus quadratic terms: also exact for quadratic fields, so bending near a
    /// surface is right. Same cost per step (only the rest stencil changes); falls back to
    /// linear where the neighbourhood cannot support a quadratic fit.
    #[default]
    Quadratic,
}
