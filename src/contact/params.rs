//! Contact constants of a pair from the two materials (Keiser et al. 2004, §7): the
//! penalty spring, dashpot and friction of [`ContactParams`], the support of the force
//! distribution, and the stable step the penalty spring allows.

use crate::body::object::Object;
use crate::dynamics::damped_euler_limit;
use crate::material::Material;

/// Contact-response constants of one pair, from the two materials.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactParams {
    /// Surface weights λ = Young's modulus (paper §6), normalised to sum 1.
    pub lambda_a: f32,
    pub lambda_b: f32,
    /// Penalty spring stiffness per area (N/m³).
    pub stiffness: f32,
    /// Penalty damping per area (N·s/m³).
    pub damping: f32,
    /// Coulomb friction coefficient.
    pub friction: f32,
    /// Target spacing of contact surfels (m).
    pub spacing: f32,
    /// Spacing of the denser side's force-carrying contact surfels (m, ≥ `spacing`;
    /// equal to it when neither side is thinned): the support of their area estimate.
    pub force_spacing: f32,
}

pub use crate::body::object::DISTRIBUTION_SUPPORT;

/// Hertz compliance `(1 − ν²)/E` of a material: a pair's `E* = 1/(c_a + c_b)`.
pub(crate) fn compliance(m: &Material) -> f32 {
    (1.0 - m.poisson * m.poisson) / m.young
}

/// Contact constants of a pair from the two materials (docs/ARCHITECTURE.md).
pub fn contact_params(a: &Object, b: &Object, dt: f32) -> ContactParams {
    let (ma, mb) = (&a.material, &b.material);
    let e_star = 1.0 / (compliance(ma) + compliance(mb));
    // The moving objects set the scale (both when neither moves).
    let any_moving = !a.is_static() || !b.is_static();
    let pick = [a, b]
        .into_iter()
        .filter(move |o| !any_moving || !o.is_static());
    let h = pick
        .clone()
        .map(|o| o.phyxel_spacing)
        .fold(f32::INFINITY, f32::min);
    let rho = pick
        .map(|o| o.material.density)
        .fold(f32::INFINITY, f32::min);
    let stiffness = 0.5 * (ma.contact_stiffness + mb.contact_stiffness) * e_star / h;
    let zeta = 0.5 * (ma.contact_damping + mb.contact_damping);
    ContactParams {
        lambda_a: ma.young / (ma.young + mb.young),
        lambda_b: mb.young / (ma.young + mb.young),
        stiffness,
        // Explicit integration damps stably only while c·dt < 2 m for the surface layer
        // (mass ρh per area) that takes the force: cap at 1.6 ρh/dt. A pair whose
        // dashpot is in an implicit solve (backward Euler: stable for any c) is not
        // capped.
        damping: if a.contact_in_solve(b) {
            2.0 * zeta * (stiffness * rho * h).sqrt()
        } else {
            (2.0 * zeta * (stiffness * rho * h).sqrt()).min(1.6 * rho * h / dt)
        },
        friction: (ma.friction * mb.friction).sqrt(),
        spacing: a.surfel_spacing.min(b.surfel_spacing),
        // The denser side's carriers set the density of Φ (without thinning: the
        // surfel spacing, as `spacing`).
        force_spacing: a.carrier_spacing.min(b.carrier_spacing),
    }
}

/// Thickness of the layer, in phyxel spacings, whose mass the contact spring moves: the
/// force spreads over the phyxels within twice the influence radius. Calibrated on the
/// stiffest backend for contact (`lj`, `two-spheres`, dt 0.8 ms): stable at
/// `contact_stiffness` 128, unstable at 256, which this layer puts at the bound.
pub const CONTACT_LAYER_SPACINGS: f32 = 2.5;
/// The layer, in spacings, that a body of `phyxels` phyxels can put behind its contact
/// surface: [`CONTACT_LAYER_SPACINGS`], or the body's own thickness (about `n^(1/3)`
/// spacings) when it is thinner. A one-phyxel body is one spacing thick: at the 2.5
/// spacings' bound two such spheres leave a collision with twice their energy.
pub fn contact_layer(phyxels: usize) -> f32 {
    CONTACT_LAYER_SPACINGS.min((phyxels.max(1) as f32).cbrt())
}

/// Margin of the contact bound below the explicit limit (as the backends' own).
const CONTACT_STABILITY_MARGIN: f32 = 0.8;

/// Largest stable step (s) of the penalty spring `k = contact_stiffness · E*/h_pair` per
/// contact area (`h_pair`: the pair's finest moving phyxel spacing, as in
/// [`contact_params`]) acting on a layer of [`CONTACT_LAYER_SPACINGS`] of the object's
/// own spacings `h` of mass (`ρ · 2.5 h` per area): `0.8 · 2/ω` with
/// `ω² = k / (2.5 ρ h)`. With the default stiffness it is several times the elastic
/// bound; it binds when `contact_stiffness` is raised by orders of magnitude
/// (docs/SCENES.md, "Time step").
pub fn contact_stable_dt(
    contact_stiffness: f32,
    e_star: f32,
    density: f32,
    spacing: f32,
    pair_spacing: f32,
    phyxels: usize,
) -> f32 {
    let k = contact_stiffness * e_star / pair_spacing;
    let omega = (k / (contact_layer(phyxels) * density * spacing)).sqrt();
    CONTACT_STABILITY_MARGIN * damped_euler_limit(omega, 0.0)
}
