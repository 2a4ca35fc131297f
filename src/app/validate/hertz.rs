//! Hertz contact of an elastic sphere pressed onto a rigid plane, measured from the
//! contact output: the load the contact carries, the patch radius, the central pressure,
//! the pressure profile and the approach (Johnson, *Contact Mechanics*, §4.2).
//!
//! The sphere (radius R, E, ν) rests on a static plane (E 10⁴ times the sphere's, so
//! `1/E* = (1 − ν²)/E + (1 − ν_p²)/E_p` is the rigid plane's to 1e-4) and is pressed by a
//! load F spread over its phyxels (a body force, ramped over 0.3 s, no gravity; times
//! scale as `R √(ρ/E)`, [`time_scale`]). A sphere on a plane is in stable equilibrium,
//! unlike two spheres pressed together. Friction is off: Hertz's contact is
//! frictionless.
//!
//! The measurement is of the state at rest, so the harness settles the sphere: after
//! each step it scales the sphere's phyxel velocities by `e^{−α dt}`, a drag `α = 1.4 ω`
//! on the bounce of the sphere's mass m on Hertz's contact stiffness `2E*a`
//! (`ω² = 2E*a/m`). A drag does no work on a body at rest, so it leaves that state as it
//! is. The contact dashpot does not settle it: it acts on the overlap's rate, which is
//! the penalty layer's share of the approach (a few to 26%), so it damps the bounce at a
//! damping ratio of about 0.005, and without the drag the contact force swings ±30%
//! about the load through the run. [`HertzRun::force_swing`] reports what is left.
//! References, with `a ≪ R`:
//! - force balance: at rest the contact carries the load, `Σ f_n = F`;
//! - patch radius `a = (3FR/(4E*))^{1/3}`, measured from the second moment of the normal
//!   force over the patch: under `p = p₀ √(1 − r²/a²)`, `Σ f r² / Σ f = 2a²/5`;
//! - central pressure `p₀ = 3F/(2πa²)`: the mean pressure over `r < a/2` is
//!   `0.9349 p₀` (the integral of the profile);
//! - approach `δ = a²/R = (9F²/(16 R E*²))^{1/3}`: the sphere's centre drop minus the
//!   penalty overlap at the centre includes the compression of the body under its
//!   body-force load, which linear elasticity makes exactly linear in F (the body force
//!   and the contact force are both proportional to F, and the contact's resultant acts
//!   R away, where a patch of radius a differs from a point load by `O(a²/R²)`). Runs at
//!   three loads fit `δ(F) = c F^{2/3} + b F`; `c` is compared with Hertz's
//!   `(9/(16 R E*²))^{1/3}`.

use super::*;
use crate::contact::ContactPoint;

/// A sphere-on-plane case: sphere radius (m), Young's modulus (Pa), Poisson ratio, and
/// resolution as phyxels across the radius (surfel spacing a fifth of the phyxel
/// spacing).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HertzCase {
    pub radius: f32,
    pub young: f32,
    pub poisson: f32,
    pub per_radius: f32,
    /// Forces on the resampled contact surface (`World::resampled_forces`); false: as
    /// the preset says.
    pub resampled_forces: bool,
    /// Both materials' `contact_stiffness` (penalty spring per area in `E*/h`); `None`:
    /// the default.
    pub contact_stiffness: Option<f32>,
    /// Graded sampling: the sphere's phyxels this many per radius within
    /// [`REFINED_ZONE`] R of its contact point (`per_radius` elsewhere), and the
    /// plane's at the same spacing; `None`: uniform.
    pub refined_per_radius: Option<f32>,
}

/// Radius of the graded sphere's refined zone about its contact point, in R: twice the
/// largest patch radius the studies load to (0.19 R), so the patch and the bulk under
/// it to a depth of about its radius are fine.
pub const REFINED_ZONE: f32 = 0.4;

/// What one loaded run measured, averaged over the run's last 0.3 s (scaled by
/// [`time_scale`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct HertzRun {
    /// The load (N) and the normal force the contact carried (N).
    pub load: f64,
    pub contact_force: f64,
    /// Patch radius (m) from the force's second moment, and Hertz's.
    pub radius: f64,
    pub hertz_radius: f64,
    /// Central pressure (Pa), and Hertz's `3F/(2πa²)`.
    pub pressure: f64,
    pub hertz_pressure: f64,
    /// RMS of `p(r) − p₀√(1 − r²/a²)` over the contact surfels, as a fraction of Hertz's
    /// p₀ (with Hertz's a).
    pub profile_rms: f64,
    /// Centre drop minus the overlap at the centre (m).
    pub approach: f64,
    /// Largest minus smallest contact force over the averaging window, over the load:
    /// how far the sphere is from rest.
    pub force_swing: f64,
    pub info: RunInfo,
}

/// Load (N) at which Hertz's patch radius is `ratio` R.
pub fn load_for(case: &HertzCase, ratio: f64) -> f64 {
    let r = case.radius as f64;
    4.0 * e_star_plane(case) * r * r * ratio.powi(3) / 3.0
}

/// The plane's Young's modulus in units of the sphere's, and its Poisson ratio.
const PLANE_STIFFNESS: f64 = 1.0e4;
const PLANE_POISSON: f64 = 0.3;

/// `E*` of the sphere on the plane, from both materials.
fn e_star_plane(case: &HertzCase) -> f64 {
    let compliance = |e: f64, nu: f64| (1.0 - nu * nu) / e;
    let e = case.young as f64;
    1.0 / (compliance(e, case.poisson as f64) + compliance(PLANE_STIFFNESS * e, PLANE_POISSON))
}

/// The scene of `case` pressed by `load` (N).
pub fn hertz_plane_scene(case: &HertzCase, load: f64) -> Scene {
    let r = case.radius;
    let h = r / case.per_radius;
    // The contact's spacing: the refined zone's where there is one.
    let fine = r / case.refined_per_radius.unwrap_or(case.per_radius);
    let s = fine / 5.0;
    let refine = match case.refined_per_radius {
        Some(_) => format!(
            "refine = [{{ centre = [0.0, {}, 0.0], radius = {}, spacing = {fine} }}]",
            -r,
            REFINED_ZONE * r
        ),
        None => String::new(),
    };
    // Four times the largest patch radius measured (0.2 R).
    let patch = 0.8 * r;
    let text = format!(
        r#"
        name = "hertz-plane"
        gravity = [0.0, 0.0, 0.0]
        # Measured at rest: a sleeping body's contact is not evaluated.
        sleep = false
        {resampled}
        [[objects]]
        name = "plane"
        shape = {{ type = "plane", size = [{patch}, {patch}] }}
        spacing = {fine}
        surfel_spacing = {s}
        static = true
        material = {{ young = {ep}, poisson = {np}, friction = 0.0{kappa} }}
        [[objects]]
        name = "sphere"
        shape = {{ type = "sphere", radius = {r} }}
        spacing = {h}
        surfel_spacing = {sphere_s}
        {refine}
        position = [0.0, {y}, 0.0]
        load = [0.0, {f}, 0.0]
        load_ramp = {ramp}
        material = {{ density = 1000.0, young = {e}, poisson = {nu}, damping = {damping}, contact_damping = 4.0, friction = 0.0{kappa} }}
        "#,
        sphere_s = h / 5.0,
        ep = PLANE_STIFFNESS * case.young as f64,
        np = PLANE_POISSON,
        y = r + 0.05 * s,
        f = -load,
        e = case.young,
        nu = case.poisson,
        ramp = RAMP * time_scale(case),
        // Unset, the preset decides.
        resampled = if case.resampled_forces {
            "resampled_forces = true"
        } else {
            ""
        },
        damping = 2.0e-4 * time_scale(case),
        kappa = case
            .contact_stiffness
            .map(|k| format!(", contact_stiffness = {k}"))
            .unwrap_or_default(),
    );
    Scene::parse(&text, "hertz-plane").expect("hertz-plane scene")
}

/// Simulated time of a run, the final window averaged over, and the load ramp (s), for
/// R = 0.1 m and E = 1e5 Pa (scaled by [`time_scale`]): the settling drag stops the
/// sphere's bounce on the contact (period about 0.2 s there) within 0.5 s.
const RUN: f32 = 1.0;
const WINDOW: f32 = 0.3;
const RAMP: f32 = 0.3;

/// The settling drag in units of the bounce's angular frequency ω (twice its damping
/// ratio; module docs).
const SETTLING_DRAG: f64 = 1.4;

/// The case's time scale against R = 0.1 m, E = 1e5 Pa: elastic times go as
/// `R √(ρ/E)`, so every case takes the same number of steps.
pub fn time_scale(case: &HertzCase) -> f32 {
    case.radius / 0.1 * (1.0e5 / case.young).sqrt()
}

/// Runs `case` at `load` (N) with `backend`.
pub fn hertz_plane(case: &HertzCase, load: f64, backend: &str) -> Result<HertzRun, String> {
    let scene = hertz_plane_scene(case, load);
    let mut w = build(&scene, &opts(backend))?;
    let r = case.radius as f64;
    let es = e_star_plane(case);
    let a_h = (3.0 * load * r / (4.0 * es)).cbrt();
    let p_h = 3.0 * load / (2.0 * std::f64::consts::PI * a_h * a_h);
    let t = time_scale(case);
    let steps = (RUN * t / w.dt) as usize;
    let from = ((RUN - WINDOW) * t / w.dt) as usize;
    let mass: f64 = w.objects[1].phyxels.mass.iter().map(|&m| m as f64).sum();
    let omega = (2.0 * es * a_h / mass).sqrt();
    let keep = (-SETTLING_DRAG * omega * w.dt as f64).exp() as f32;
    let (mut k, mut n) = (0usize, 0usize);
    let mut sum = HertzRun::default();
    let (mut least, mut most) = (f64::INFINITY, 0.0f64);
    let info = timed_mut(&mut w, steps, |w| {
        let vel = &mut w.objects[1].phyxels.vel;
        for j in 0..vel.len() {
            vel.set(j, keep * vel.get(j));
        }
        k += 1;
        if k < from {
            return true;
        }
        let Some(patch) = w.contact.patches.first() else {
            return true;
        };
        let pts: Vec<ContactPoint> = patch.surfels.iter().map(ContactPoint::of).collect();
        let f_n = |p: &ContactPoint| Vec3::from(p.penalty_force).length() as f64;
        let load_carried: f64 = pts.iter().map(f_n).sum();
        if load_carried <= 0.0 {
            return true;
        }
        // The force-weighted centre of the patch, in the plane (x, z).
        let centre = pts.iter().fold(DVec3::ZERO, |c, p| {
            c + Vec3::from(p.position).as_dvec3() * f_n(p)
        }) / load_carried;
        let r2 = |p: &ContactPoint| {
            let d = Vec3::from(p.position).as_dvec3() - centre;
            d.x * d.x + d.z * d.z
        };
        let second = pts.iter().map(|p| f_n(p) * r2(p)).sum::<f64>() / load_carried;
        let a = (2.5 * second).sqrt();
        let inner: Vec<&ContactPoint> = pts.iter().filter(|p| r2(p) < 0.25 * a * a).collect();
        let inner_area: f64 = inner.iter().map(|p| p.area as f64).sum();
        let inner_force: f64 = inner.iter().map(|p| f_n(p)).sum();
        let p0 = if inner_area > 0.0 {
            inner_force / inner_area / 0.9349
        } else {
            0.0
        };
        let profile = (pts
            .iter()
            .filter(|p| p.area > 0.0)
            .map(|p| {
                let hertz = p_h * (1.0 - r2(p) / (a_h * a_h)).max(0.0).sqrt();
                (f_n(p) / p.area as f64 - hertz).powi(2)
            })
            .sum::<f64>()
            / pts.len() as f64)
            .sqrt()
            / p_h;
        let deepest = pts.iter().map(|p| p.penetration as f64).fold(0.0, f64::max);
        let drop = r - com(w, 1).y;
        least = least.min(load_carried);
        most = most.max(load_carried);
        sum.contact_force += load_carried;
        sum.radius += a;
        sum.pressure += p0;
        sum.profile_rms += profile;
        sum.approach += drop - deepest;
        n += 1;
        true
    });
    let n = n.max(1) as f64;
    Ok(HertzRun {
        load,
        contact_force: sum.contact_force / n,
        radius: sum.radius / n,
        hertz_radius: a_h,
        pressure: sum.pressure / n,
        hertz_pressure: p_h,
        profile_rms: sum.profile_rms / n,
        approach: sum.approach / n,
        force_swing: if most >= least {
            (most - least) / load
        } else {
            f64::INFINITY
        },
        info,
    })
}

/// Least-squares `δ = c F^{2/3} + b F` over `runs`: `(c, b)`.
pub fn approach_fit(runs: &[HertzRun]) -> (f64, f64) {
    let (mut a11, mut a12, mut a22, mut r1, mut r2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for run in runs {
        let (x1, x2) = (run.load.powf(2.0 / 3.0), run.load);
        a11 += x1 * x1;
        a12 += x1 * x2;
        a22 += x2 * x2;
        r1 += x1 * run.approach;
        r2 += x2 * run.approach;
    }
    let det = a11 * a22 - a12 * a12;
    ((r1 * a22 - r2 * a12) / det, (a11 * r2 - a12 * r1) / det)
}

/// Hertz's approach coefficient `(9/(16 R E*²))^{1/3}` of `case` (m/N^{2/3}).
pub fn hertz_approach_coefficient(case: &HertzCase) -> f64 {
    let es = e_star_plane(case);
    (9.0 / (16.0 * case.radius as f64 * es * es)).cbrt()
}
