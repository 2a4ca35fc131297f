//! The validation suite behind `phyxel validate`: every case against an independent
//! reference, at several resolutions (or time steps), for every backend it applies to,
//! with the wall time per step so speed can be set against error (docs/ACCURACY.md).
//!
//! One function per case returns its [`Row`]s; the measurements they share (cantilever
//! response, Hertz indentation, incline, ...) are public so tests call them directly.
//! [`stability`] runs the hard cases, which must either run stable or be refused.

use crate::World;
use crate::backends;
use crate::body::material::Material;
use crate::body::phyxels::Phyxels;
use crate::body::shape::Shape;
use crate::scene::{BuildOptions, Scene};
use glam::{DMat3, DVec3, Mat3, Vec3};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// One line of the report.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Row {
    /// Case name, e.g. `cantilever-deflection`.
    pub case: String,
    /// `accuracy` or `stability`.
    pub group: String,
    pub backend: String,
    /// Phyxels over all deformable objects.
    pub phyxels: usize,
    /// Surfels over all objects.
    pub surfels: usize,
    /// Time step (s).
    pub dt: f32,
    /// Wall seconds per step, all phases.
    pub seconds_per_step: f64,
    /// The measured value (unit per case, see [`CASES`]).
    pub measured: f64,
    /// The reference value, same unit.
    pub reference: f64,
    /// `|measured − reference| / |reference|`, or the case's own normalisation where the
    /// reference is zero (see [`CASES`]).
    pub rel_error: f64,
    pub tolerance: f64,
    pub pass: bool,
    /// Accuracy rows: `pass` or `fail`; stability rows: `stable`, `refused` or `unstable`.
    pub status: String,
    /// What was measured, or the refusal message.
    pub note: String,
}

/// The accuracy cases: (name, what is measured against what, whether the error is
/// resolution-driven, i.e. must fall from the coarsest to the finest resolution).
pub const CASES: &[(&str, &str, bool)] = &[
    (
        "mls-consistency",
        "largest gradient of a random affine field, Frobenius norm, vs the field's matrix (error relative to |B|; f32 round-off, not resolution-driven)",
        false,
    ),
    (
        "cantilever-deflection",
        "tip deflection (m) vs Euler–Bernoulli qL⁴/(8EI)",
        true,
    ),
    (
        "cantilever-frequency",
        "first bending frequency (Hz) vs (1.875²/2π)√(EI/(ρAL⁴))",
        true,
    ),
    (
        "hertz-indentation",
        "approach of the centres (m) of two spheres pressed by 5 N vs Hertz (9F²/(16E*²R*))^(1/3)",
        false,
    ),
    (
        "hertz-exponent",
        "exponent n fitted to F ∝ δⁿ over 2.5, 5, 10 N vs Hertz's 1.5",
        false,
    ),
    (
        "hertz-impact",
        "largest approach of the centres (m) of two spheres colliding vs (15m*v²/(16E*√R*))^(2/5)",
        false,
    ),
    (
        "incline-stick",
        "creep (m) of a block in 0.5 s on a 20° incline, μ = 0.5; reference 0, error relative to the 0.1 m block",
        true,
    ),
    (
        "incline-slide",
        "sliding acceleration (m/s²) on a 30° incline, μ = 0.3, vs g(sin θ − μ cos θ)",
        false,
    ),
    (
        "momentum-collision",
        "largest |total momentum| through a collision of two spheres (kg·m/s); reference 0, error relative to one sphere's momentum",
        false,
    ),
    (
        "energy-free-body",
        "kinetic + elastic energy (J) of a free undamped sphere released from a 2% stretch: the mean over the last fifth of the run against the mean over the first fifth",
        true,
    ),
    (
        "energy-initial",
        "elastic energy (J) the backend reports for the free sphere of `energy-free-body` in its initial 2% stretch vs the closed form of its energy model for that homogeneous stretch (`stretch_energy`)",
        false,
    ),
    (
        "newtons-cradle",
        "momentum of the last of five spheres (kg·m/s) vs the incoming momentum (ideal elastic cradle)",
        false,
    ),
];

/// The stability cases (hard cases), each run or refused.
pub const STABILITY_CASES: &[&str] = &[
    "stiff-material",
    "dt-at-bound",
    "dt-above-bound",
    "high-speed-impact",
    "deep-penetration",
    "one-phyxel-plate",
];

/// Whether `case` applies to `backend`. MLS consistency is a property of the MLS
/// gradient fit (Müller et al. 2004, eq. 7), so it runs for `mls` only; every other
/// case is backend-neutral physics and runs for every backend (`energy-free-body` gives
/// no rows for a backend that reports no elastic energy).
///
/// `energy-free-body` does not apply to `sph`: its weakly compressible solver always
/// carries Monaghan's artificial viscosity (α = 0.1), which dissipates a free body's
/// vibration (measured: 59% of the energy in 0.2 s, the same at every dt), so the case,
/// which checks that the integrator conserves the energy of an undamped body, has no
/// undamped SPH body to check. `energy-initial` does not apply to `sph` either:
/// [`stretch_energy`] has no closed form for its kernel-sum density at a free surface.
pub fn applies(case: &str, backend: &str) -> bool {
    match case {
        "mls-consistency" => backend == "mls",
        "energy-free-body" | "energy-initial" => backend != "sph",
        _ => true,
    }
}

/// Tolerance of `case` for `backend` (relative error). The MLS figures are the suite's
/// defaults. The Hertz exponent of a coarse particle body (SPH, LJ) is stiffer than 1.5
/// (docs/ACCURACY.md: at a few particles across, the surface particles have fewer
/// neighbours). Every other case has the same tolerance for every backend, except where
/// a case sets one per row: the cantilever per backend and resolution
/// ([`cantilever_tolerance`]), the free body's energy per backend and dt
/// ([`energy_tolerance`]) and the cradle per resolution ([`CRADLE_ROWS`]).
pub fn tolerance(case: &str, backend: &str, default: f64) -> f64 {
    match (case, backend) {
        ("hertz-exponent", "sph" | "lj") => 0.20,
        _ => default,
    }
}

/// Cantilever tolerances `(deflection, frequency)` (relative error) of `backend` with
/// `through` phyxels through the beam's thickness (quick suite 3, 4, 5; full 4, 6, 8).
///
/// MLS: 15% and 10% at every resolution (measured 5.2–12.7% and 3.4–7.1%). The particle
/// backends' beams are too soft where their first-order surface treatment shows: the
/// outer fibres, which carry the bending stress, have fewer neighbours (SPH: a truncated
/// kernel; LJ: fewer bonds). Their errors fall steeply with resolution (asserted), so one
/// bound for every row would be several times the finer rows' errors; each row gets
/// about twice its measured error instead, or about 10 points above it where the error
/// is large (the errors are deterministic: an AVX2+FMA and a baseline x86-64 build gave
/// the same errors to 3 digits). Measured deflection / frequency errors (%):
///
/// | through | SPH | LJ |
/// |---|---|---|
/// | 3 | 35.6 / 15.2 | 73.7 / 25.1 |
/// | 4 | 18.6–19.0 / 9.1–9.5 | 55.9–56.1 / 20.7–20.8 |
/// | 5 | 4.9 / 3.3 | 35.7 / 14.9 |
/// | 6 | 4.9 / 3.3 | 32.9 / 13.9 |
/// | 8 | 0.84 / 1.3 | 23.3 / 10.5 |
///
/// At 3 through (and LJ's frequency at 4) the earlier one-per-backend bounds stay, SPH
/// 40% / 20% and LJ 80% / 30%, where twice the error would be looser. An SPH shear
/// modulus doubled in the stress (a mutation check) passed those at every quick row (16%,
/// 28%, 37% too stiff at 3, 4, 5 through); it now fails at 5 (and the frequency at 4, 5).
pub fn cantilever_tolerance(backend: &str, through: u32) -> (f64, f64) {
    match (backend, through) {
        ("sph", ..=3) => (0.40, 0.20),
        ("sph", 4) => (0.30, 0.15),
        ("sph", 5..=6) => (0.10, 0.07),
        ("sph", _) => (0.02, 0.03),
        ("lj", ..=3) => (0.80, 0.30),
        ("lj", 4) => (0.65, 0.30),
        ("lj", 5) => (0.45, 0.25),
        ("lj", 6) => (0.42, 0.24),
        ("lj", _) => (0.32, 0.20),
        _ => (0.15, 0.10),
    }
}

/// Size and speed of one run.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunInfo {
    pub phyxels: usize,
    pub surfels: usize,
    pub dt: f32,
    pub seconds_per_step: f64,
}

/// Steps `world` while timing the steps; `observe` sees the world after each step and
/// returns false to stop.
fn timed(world: &mut World, max_steps: usize, mut observe: impl FnMut(&World) -> bool) -> RunInfo {
    let mut wall = 0.0;
    let mut steps = 0;
    for _ in 0..max_steps {
        let t = Instant::now();
        world.step();
        wall += t.elapsed().as_secs_f64();
        steps += 1;
        if !observe(world) {
            break;
        }
    }
    RunInfo {
        phyxels: world
            .objects
            .iter()
            .filter(|o| !o.is_static())
            .map(|o| o.phyxels.len())
            .sum(),
        surfels: world.objects.iter().map(|o| o.surfels.len()).sum(),
        dt: world.dt,
        seconds_per_step: wall / steps.max(1) as f64,
    }
}

fn opts(backend: &str) -> BuildOptions {
    BuildOptions {
        backend: Some(backend.to_string()),
        ..Default::default()
    }
}

fn builtin(name: &str) -> Scene {
    Scene::builtin(name).expect("built-in scene")
}

fn build(scene: &Scene, o: &BuildOptions) -> Result<World, String> {
    scene.build(o).map_err(|e| e.to_string())
}

/// Centre of mass of object `k` (m).
pub fn com(w: &World, k: usize) -> DVec3 {
    DVec3::from(w.objects[k].phyxels.centre_of_mass())
}

/// `|m − r| / |r|`.
fn rel(m: f64, r: f64) -> f64 {
    ((m - r) / r).abs()
}

fn row(case: &str, backend: &str, run: RunInfo, measured: f64, reference: f64) -> Row {
    Row {
        case: case.into(),
        group: "accuracy".into(),
        backend: backend.into(),
        phyxels: run.phyxels,
        surfels: run.surfels,
        dt: run.dt,
        seconds_per_step: run.seconds_per_step,
        measured,
        reference,
        rel_error: rel(measured, reference),
        tolerance: 0.0,
        pass: false,
        status: String::new(),
        note: String::new(),
    }
}

/// Sets the tolerance and the verdict (NaN never passes).
fn judged(mut r: Row, tolerance: f64) -> Row {
    let tolerance = self::tolerance(&r.case, &r.backend, tolerance);
    r.tolerance = tolerance;
    r.pass = r.rel_error.is_finite() && r.rel_error <= tolerance;
    r.status = if r.pass { "pass" } else { "fail" }.into();
    r
}

/// One measurement of a sweep: the value, its reference, the run, a note, and the
/// relative error where the reference is zero (otherwise `|m − r| / |r|`).
struct Point {
    measured: f64,
    reference: f64,
    run: RunInfo,
    note: String,
    rel_error: Option<f64>,
}

/// One judged row of `case` per knob value (spacing or dt), one tolerance for all.
fn sweep<K: Copy>(
    case: &str,
    backend: &str,
    tolerance: f64,
    knobs: &[K],
    measure: impl FnMut(K) -> Result<Point, String>,
) -> Result<Vec<Row>, String> {
    sweep_by(case, backend, |_| tolerance, knobs, measure)
}

/// [`sweep`] with a tolerance per knob value.
fn sweep_by<K: Copy>(
    case: &str,
    backend: &str,
    tolerance: impl Fn(K) -> f64,
    knobs: &[K],
    mut measure: impl FnMut(K) -> Result<Point, String>,
) -> Result<Vec<Row>, String> {
    knobs
        .iter()
        .map(|&k| {
            let p = measure(k)?;
            let mut r = row(case, backend, p.run, p.measured, p.reference);
            r.rel_error = p.rel_error.unwrap_or(r.rel_error);
            r.note = p.note;
            Ok(judged(r, tolerance(k)))
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// MLS consistency

/// Largest relative error `max_i |∇u_i − B| / |B|` (Frobenius) of the MLS displacement
/// gradient over every phyxel of a box sampled at `spacing`, for five random affine
/// fields `u = B x + c` (|B| ≈ 0.05); also the Frobenius norm of the worst gradient and
/// of its B. Reference: B exactly (first-order consistency, Müller et al. 2004 eq. 7).
pub fn mls_consistency(spacing: f32) -> (f64, f64, f64, RunInfo) {
    use crate::backends::mls::MlsDynamics;
    let mat = Material::default();
    let v = Shape::Box {
        size: [0.2, 0.1, 0.15],
    }
    .sample_volume(spacing);
    let mut p = Phyxels::at_rest(&v.positions, v.cell_volume, mat.density);
    let mut m = MlsDynamics::new(&p, &mat);
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    let (mut worst, mut g_norm, mut b_norm, mut wall) = (0.0f64, 0.0, 0.0, 0.0);
    for _ in 0..5 {
        let b = Mat3::from_cols_array(&std::array::from_fn(|_| next() * 0.05));
        let c = Vec3::new(next(), next(), next()) * 0.01;
        for i in 0..p.len() {
            let x = p.rest.get(i);
            p.pos.set(i, x + b * x + c);
        }
        let t = Instant::now();
        m.compute_forces(&p, &mat, 1e-4);
        wall += t.elapsed().as_secs_f64();
        let grad = crate::Dynamics::displacement_gradient(&m).expect("MLS has gradients");
        let bd = DMat3::from_cols_array(&b.to_cols_array().map(|v| v as f64));
        let norm = |m: DMat3| m.to_cols_array().iter().map(|v| v * v).sum::<f64>().sqrt();
        for g in grad {
            let gd = DMat3::from_cols_array(&g.to_cols_array().map(|v| v as f64));
            let e = norm(gd - bd) / norm(bd);
            if e > worst {
                (worst, g_norm, b_norm) = (e, norm(gd), norm(bd));
            }
        }
    }
    let info = RunInfo {
        phyxels: p.len(),
        surfels: 0,
        dt: 0.0,
        seconds_per_step: wall / 5.0,
    };
    (worst, g_norm, b_norm, info)
}

/// MLS consistency rows; tolerance 1e-4 (f32 arithmetic), as in tests/mls.rs.
pub fn case_mls_consistency(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    let spacings: &[f32] = if quick {
        &[0.04, 0.03, 0.02]
    } else {
        &[0.04, 0.02, 0.01]
    };
    sweep("mls-consistency", backend, 1e-4, spacings, |s| {
        let (err, g, b, run) = mls_consistency(s);
        Ok(Point {
            measured: g,
            reference: b,
            run,
            note: format!("box 0.2×0.1×0.15 m, spacing {s} m"),
            rel_error: Some(err),
        })
    })
}

// ---------------------------------------------------------------------------------------
// Cantilever

/// Euler–Bernoulli references of the built-in `cantilever` (box along x, clamped over
/// its first `fixed` region): `(δ_tip, f₁)` with `δ = qL⁴/(8EI)`, q = ρgA, I = bt³/12,
/// and `f₁ = (1.875²/2π)√(EI/(ρAL⁴))`; L is the free length.
pub fn euler_bernoulli(scene: &Scene) -> (f64, f64) {
    let o = &scene.objects[0];
    let Shape::Box { size } = o.shape else {
        panic!("the cantilever is a box")
    };
    let clamp = (o.fixed[0].max[0] - o.fixed[0].min[0]) as f64;
    let (l, t, b) = (size[0] as f64 - clamp, size[1] as f64, size[2] as f64);
    let (rho, e, g) = (
        o.material.density as f64,
        o.material.young as f64,
        -scene.gravity[1] as f64,
    );
    let (a, i) = (b * t, b * t.powi(3) / 12.0);
    let delta = rho * g * a * l.powi(4) / (8.0 * e * i);
    let f1 =
        1.875f64.powi(2) / (2.0 * std::f64::consts::PI) * (e * i / (rho * a * l.powi(4))).sqrt();
    (delta, f1)
}

/// Tip deflection (m, downwards) of the built-in `cantilever` at phyxel spacing
/// `spacing` and the period of its first mode (s).
///
/// Without damping the bar oscillates about its static shape; the time average of the
/// tip deflection over `periods` whole periods (from the 1st maximum on) is the static
/// deflection (linear response started from rest). `periods = 0` uses the first half
/// period instead, from rest to the first maximum: the mean of `δ(1 − cos ωt)` over it is
/// also δ, and the period is twice its length (a third of the cost of one whole period
/// after the first maximum; used by the quick suite).
pub fn cantilever(
    spacing: f32,
    periods: usize,
    backend: &str,
) -> Result<(f64, f64, RunInfo), String> {
    let mut scene = builtin("cantilever");
    scene.objects[0].spacing = spacing;
    scene.objects[0].surfel_spacing = Some(spacing);
    let mut world = build(&scene, &opts(backend))?;
    let bar = &world.objects[0].phyxels;
    let x_max = (0..bar.len())
        .map(|i| bar.rest.x[i])
        .fold(f32::MIN, f32::max);
    let tip: Vec<usize> = (0..bar.len())
        .filter(|&i| bar.rest.x[i] > x_max - 0.5 * spacing)
        .collect();
    let dt = world.dt as f64;
    let mut series = Vec::new();
    let mut maxima: Vec<usize> = Vec::new();
    let mut finite = true;
    let info = timed(&mut world, 200_000, |w| {
        let p = &w.objects[0].phyxels;
        let d = tip
            .iter()
            .map(|&i| (p.rest.y[i] - p.pos.y[i]) as f64)
            .sum::<f64>()
            / tip.len() as f64;
        finite = d.is_finite();
        series.push(d);
        let k = series.len();
        if k >= 3 && series[k - 2] > series[k - 3] && series[k - 2] >= series[k - 1] {
            // A maximum of the fundamental (higher modes ride on it: keep only maxima
            // well above the running mean).
            let mean = series.iter().sum::<f64>() / k as f64;
            if series[k - 2] > mean * 1.5 && maxima.last().is_none_or(|&m| k - 2 - m > 20) {
                maxima.push(k - 2);
            }
        }
        finite && maxima.len() <= periods
    });
    if maxima.len() <= periods {
        return Err(format!(
            "cantilever at spacing {spacing} m: no oscillation found (finite: {finite})"
        ));
    }
    if periods == 0 {
        let b = maxima[0] + 1;
        let mean = series[..b].iter().sum::<f64>() / b as f64;
        return Ok((mean, 2.0 * b as f64 * dt, info));
    }
    let (a, b) = (maxima[0], maxima[periods]);
    let mean = series[a..b].iter().sum::<f64>() / (b - a) as f64;
    Ok((mean, (b - a) as f64 * dt / periods as f64, info))
}

/// Cantilever rows (3, 4, 5 phyxels through the thickness in quick mode; 4, 6, 8 in
/// full mode): deflection and frequency within [`cantilever_tolerance`] at every
/// resolution (MLS: 15% and 10%), both converging (docs/ACCURACY.md explains the
/// O(spacing) error sources).
pub fn case_cantilever(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    let spacings: &[f32] = if quick {
        &[1.0 / 30.0, 0.025, 0.02]
    } else {
        &[0.025, 1.0 / 60.0, 0.0125]
    };
    // Quick: average over the first half period instead of two whole periods.
    let periods = if quick { 0 } else { 2 };
    let scene = builtin("cantilever");
    let (d_ref, f_ref) = euler_bernoulli(&scene);
    let Shape::Box { size } = scene.objects[0].shape else {
        panic!("the cantilever is a box")
    };
    let mut rows = Vec::new();
    for &s in spacings {
        let through = (size[1] / s).round() as u32;
        let (d_tol, f_tol) = cantilever_tolerance(backend, through);
        let (d, period, info) = cantilever(s, periods, backend)?;
        let mut r = row("cantilever-deflection", backend, info, d, d_ref);
        r.note = format!("spacing {s:.4} m, {through} through the thickness");
        rows.push(judged(r, d_tol));
        let mut r = row("cantilever-frequency", backend, info, 1.0 / period, f_ref);
        r.note = format!("spacing {s:.4} m, {through} through the thickness");
        rows.push(judged(r, f_tol));
    }
    Ok(rows)
}

// ---------------------------------------------------------------------------------------
// Hertz

/// `1/E* = (1 − ν₁²)/E₁ + (1 − ν₂²)/E₂` for two equal materials.
fn e_star(m: &Material) -> f64 {
    m.young as f64 / (2.0 * (1.0 - (m.poisson as f64).powi(2)))
}

/// The built-in `hertz` scene pressed by `force` (N) at phyxel spacing `spacing` (surfel
/// spacing `spacing / 5`): the approach of the two centres (m) averaged over 0.35–0.45 s
/// after the 0.3 s ramp, and Hertz's `δ = (9F²/(16E*²R*))^{1/3}` (R* = R/2).
pub fn hertz_indentation(
    force: f32,
    spacing: f32,
    backend: &str,
) -> Result<(f64, f64, RunInfo), String> {
    let mut scene = builtin("hertz");
    for (k, o) in scene.objects.iter_mut().enumerate() {
        o.load = [if k == 0 { force } else { -force }, 0.0, 0.0];
        o.spacing = spacing;
        o.surfel_spacing = Some(spacing / 5.0);
    }
    let mut w = build(&scene, &opts(backend))?;
    let steps = (0.45 / w.dt) as usize;
    let avg_from = (0.35 / w.dt) as usize;
    let (mut sum, mut n, mut k) = (0.0f64, 0, 0);
    let info = timed(&mut w, steps, |w| {
        if k >= avg_from {
            sum += 0.2 - (com(w, 1) - com(w, 0)).length();
            n += 1;
        }
        k += 1;
        true
    });
    let f = force as f64;
    let es = e_star(&scene.objects[0].material);
    let hertz = (9.0 * f * f / (16.0 * es * es * 0.05)).cbrt();
    Ok((sum / n.max(1) as f64, hertz, info))
}

/// Least-squares slope of `y` against `x`.
pub fn slope(pts: &[(f64, f64)]) -> f64 {
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
        / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>()
}

/// Hertz rows: indentation at 5 N within 20% at three spacings (the measured approach
/// includes the bulk compression of body-loaded spheres, ≈ F/(ER), so it is not
/// resolution-driven); the exponent fitted over 2.5, 5, 10 N within 0.15 of 1.5
/// (a relative tolerance of 0.1) at the middle spacing.
pub fn case_hertz(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    let spacings: &[f32] = if quick {
        &[1.0 / 30.0, 0.03, 0.025]
    } else {
        &[0.025, 0.02, 1.0 / 60.0]
    };
    let mut at_5n = Vec::new();
    let mut rows = sweep("hertz-indentation", backend, 0.2, spacings, |s| {
        let (d, h, run) = hertz_indentation(5.0, s, backend)?;
        at_5n.push((d, run));
        Ok(Point {
            measured: d,
            reference: h,
            run,
            note: format!("spacing {s:.4} m, F = 5 N"),
            rel_error: None,
        })
    })?;
    let s = spacings[1];
    let mut pts = Vec::new();
    let mut total = RunInfo::default();
    for f in [2.5f32, 5.0, 10.0] {
        let (d, info) = if f == 5.0 {
            at_5n[1]
        } else {
            let (d, _, info) = hertz_indentation(f, s, backend)?;
            (d, info)
        };
        pts.push((d.ln(), (f as f64).ln()));
        total = RunInfo {
            seconds_per_step: total.seconds_per_step + info.seconds_per_step / 3.0,
            ..info
        };
    }
    let mut r = row("hertz-exponent", backend, total, slope(&pts), 1.5);
    r.note = format!("spacing {s:.4} m, F = 2.5, 5, 10 N");
    rows.push(judged(r, 0.1));
    Ok(rows)
}

/// The scene's own error figure, where it has one: for two equal spheres of one
/// material pressed together by equal and opposite loads without gravity (the `hertz`
/// scene), the relative error of the centres' approach at the end of the run against
/// Hertz `δ = (9F²/(16E*²R*))^{1/3}` (as `hertz-indentation`, which averages over the
/// last 0.1 s instead). `None` for other scenes, or when the run ended before the load
/// ramp did.
pub fn scene_error(scene: &Scene, summary: &crate::app::summary::RunSummary) -> Option<f64> {
    let [a, b] = &scene.objects[..] else {
        return None;
    };
    let (Shape::Sphere { radius: ra }, Shape::Sphere { radius: rb }) = (&a.shape, &b.shape) else {
        return None;
    };
    let load = Vec3::from(a.load);
    let time = summary.steps as f64 * summary.dt as f64;
    if ra != rb
        || a.material != b.material
        || a.is_static
        || b.is_static
        || scene.gravity != [0.0; 3]
        || load == Vec3::ZERO
        || Vec3::from(b.load) != -load
        || time < a.load_ramp.max(b.load_ramp) as f64
        || summary.bodies.len() != 2
    {
        return None;
    }
    let f = load.length() as f64;
    let r = *ra as f64;
    let es = e_star(&a.material);
    let hertz = (9.0 * f * f / (16.0 * es * es * (0.5 * r))).cbrt();
    let c = |k: usize| DVec3::from(summary.bodies[k].com);
    let approach = 2.0 * r - (c(1) - c(0)).length();
    Some(rel(approach, hertz))
}

/// Two spheres of the `two-spheres` scene (R = 0.1 m, E = 1e5 Pa, ν = 0.3, default
/// damping) flying at each other at `speed` each at phyxel spacing `spacing` (surfel
/// spacing `spacing / 5`): the largest approach of the centres (m) and Hertz's impact
/// `δ_max = (15 m* v²/(16 E* √R*))^{2/5}`, v the closing speed, m* = m/2, R* = R/2.
pub fn hertz_impact(
    spacing: f32,
    speed: f32,
    backend: &str,
) -> Result<(f64, f64, RunInfo), String> {
    let mut scene = builtin("two-spheres");
    for (k, o) in scene.objects.iter_mut().enumerate() {
        let side = if k == 0 { -1.0 } else { 1.0 };
        o.spacing = spacing;
        o.surfel_spacing = Some(spacing / 5.0);
        o.position = [side * 0.102, 0.0, 0.0];
        o.velocity = [-side * speed, 0.0, 0.0];
    }
    let mut w = build(&scene, &opts(backend))?;
    let m = w.objects[0].phyxels.total_mass();
    let es = e_star(&scene.objects[0].material);
    let v = 2.0 * speed as f64;
    let reference = (15.0 * (m / 2.0) * v * v / (16.0 * es * 0.05f64.sqrt())).powf(0.4);
    let c0 = (com(&w, 1) - com(&w, 0)).length();
    let mut deepest = 0.0f64;
    // Until the spheres separate again (well past the half-contact time).
    let steps = (0.3 / w.dt) as usize;
    let info = timed(&mut w, steps, |w| {
        let d = c0 - (com(w, 1) - com(w, 0)).length() - 0.004;
        deepest = deepest.max(d);
        !(d < 0.0 && deepest > 0.0)
    });
    Ok((deepest, reference, info))
}

/// Hertz impact rows at closing speed 0.2 m/s (δ_max ≈ 8 mm, 8% of R): within 25%.
pub fn case_hertz_impact(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    let spacings: &[f32] = if quick {
        &[1.0 / 30.0, 0.03, 0.025]
    } else {
        &[0.025, 0.02, 1.0 / 60.0]
    };
    sweep("hertz-impact", backend, 0.25, spacings, |s| {
        let (d, h, run) = hertz_impact(s, 0.1, backend)?;
        Ok(Point {
            measured: d,
            reference: h,
            run,
            note: format!("spacing {s:.4} m, closing speed 0.2 m/s"),
            rel_error: None,
        })
    })
}

// ---------------------------------------------------------------------------------------
// Coulomb incline

/// The `incline` scene at `angle` (degrees) and friction `mu` with time step `dt`: the
/// block's displacement down the slope over `time` s after a `settle` s landing (surfel
/// spacing `surfel_spacing`, 5 mm in the scene), and
/// its acceleration (m/s²) from a least-squares fit of `s0 + v0 t + a t²/2` over that time.
pub fn incline(
    angle: f32,
    mu: f32,
    dt: f32,
    settle: f32,
    time: f32,
    surfel_spacing: f32,
    backend: &str,
) -> Result<(f64, f64, RunInfo), String> {
    let mut scene = builtin("incline");
    for o in scene.objects.iter_mut() {
        o.surfel_spacing = Some(surfel_spacing);
    }
    if surfel_spacing > 0.005 {
        // Coarse runs: a 1 m slope is long enough for 0.35 s of sliding.
        scene.objects[0].shape = Shape::Plane { size: [1.0, 0.3] };
    }
    let th = angle.to_radians();
    let n = Vec3::new(-th.sin(), th.cos(), 0.0);
    for o in scene.objects.iter_mut() {
        o.rotation = [0.0, 0.0, angle];
        o.material.friction = mu;
    }
    scene.objects[1].position = (n * 0.0255).to_array();
    scene.dt = Some(dt);
    let mut w = build(&scene, &opts(backend))?;
    let down = DVec3::new(-th.cos() as f64, -th.sin() as f64, 0.0);
    timed(&mut w, (settle / dt) as usize, |_| true);
    let x0 = com(&w, 1).dot(down);
    let mut rows = Vec::new();
    let mut t = 0.0f64;
    let info = timed(&mut w, (time / dt) as usize, |w| {
        t += dt as f64;
        rows.push((t, com(w, 1).dot(down) - x0));
        true
    });
    let disp = rows.last().map_or(0.0, |r| r.1);
    let mut ata = [[0.0f64; 3]; 3];
    let mut atb = [0.0f64; 3];
    for &(t, s) in &rows {
        let basis = [1.0, t, 0.5 * t * t];
        for i in 0..3 {
            atb[i] += basis[i] * s;
            for j in 0..3 {
                ata[i][j] += basis[i] * basis[j];
            }
        }
    }
    let a = DMat3::from_cols_array_2d(&ata).inverse() * DVec3::from(atb);
    Ok((disp, a.z, info))
}

/// Tolerance of `incline-slide` (relative error of the fitted acceleration): measured
/// 1.6e-5 to 6.2e-5 on every backend, quick and full, on an AVX2+FMA and a baseline
/// x86-64 build, so about 3 × the largest. The friction force enters the acceleration
/// as `μ g cos θ / (g(sin θ − μ cos θ))` = 1.08 times its relative error, so a friction
/// force off by 0.05% fails.
pub const INCLINE_SLIDE_TOLERANCE: f64 = 2e-4;

/// Incline rows, the time step being the knob. Stick (20°, μ = 0.5, tan θ < μ): the
/// explicit Coulomb force chatters around v = 0 and creeps in proportion to dt; the creep
/// over the run (0.5 s; 0.1 s in quick mode) must stay below 1% of the 0.1 m block.
/// Slide (30°, μ = 0.3): acceleration `g(sin θ − μ cos θ)` within
/// [`INCLINE_SLIDE_TOLERANCE`].
pub fn case_incline(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    // Halving steps from 0.4 ms, or from 90% of the backend's stable bound if lower.
    let mut probe = builtin("incline");
    probe.dt = None;
    let bound = build(&probe, &opts(backend))?.stable_dt().0;
    let first = 4e-4f32.min(0.9 * bound);
    let halvings = if quick { 3 } else { 4 };
    let dts: Vec<f32> = (0..halvings).map(|k| first / (1 << k) as f32).collect();
    let dts = &dts[..];
    // Quick: coarser surfels (1 cm) and a shorter slope, which sets the cost per step.
    let (settle, time, ss) = if quick {
        (0.15, 0.1, 0.01)
    } else {
        (0.4, 0.5, 0.005)
    };
    let mut rows = sweep("incline-stick", backend, 0.01, dts, |dt| {
        let (disp, _, run) = incline(20.0, 0.5, dt, settle, time, ss, backend)?;
        Ok(Point {
            measured: disp,
            reference: 0.0,
            run,
            note: format!("20°, μ 0.5, creep over {time} s"),
            rel_error: Some(disp.abs() / 0.1),
        })
    })?;
    let th = 30f64.to_radians();
    let want = 9.81 * (th.sin() - 0.3 * th.cos());
    let tol = INCLINE_SLIDE_TOLERANCE;
    rows.extend(sweep("incline-slide", backend, tol, dts, |dt| {
        let (_, acc, run) = incline(30.0, 0.3, dt, settle, time, ss, backend)?;
        Ok(Point {
            measured: acc,
            reference: want,
            run,
            note: format!("30°, μ 0.3, fit over {time} s"),
            rel_error: None,
        })
    })?);
    Ok(rows)
}

// ---------------------------------------------------------------------------------------
// Conservation

/// The `two-spheres` collision at phyxel spacing `spacing` (surfel spacing `spacing/5`):
/// the largest |total momentum| over the run (kg·m/s) and one sphere's momentum.
pub fn collision_momentum(
    spacing: f32,
    backend: &str,
) -> Result<(f64, f64, bool, RunInfo), String> {
    let mut scene = builtin("two-spheres");
    for o in scene.objects.iter_mut() {
        o.spacing = spacing;
        o.surfel_spacing = Some(spacing / 5.0);
    }
    let mut w = build(&scene, &opts(backend))?;
    let scale = w.objects[0].phyxels.total_mass() * 1.0;
    let (mut worst, mut touched) = (0.0f64, false);
    let steps = (0.25 / w.dt) as usize;
    let info = timed(&mut w, steps, |w| {
        touched |= !w.patches.is_empty();
        worst = worst.max(DVec3::from(w.momentum()).length());
        true
    });
    Ok((worst, scale, touched, info))
}

/// The initial stretch of the free body of [`free_energy`] and [`initial_energy`]: the
/// principal stretches along x, y and z (a uniform 2% stretch along x).
pub const FREE_STRETCH: [f32; 3] = [1.02, 1.0, 1.0];

/// The free undamped sphere of [`free_energy`] (R = 0.1 m, E = 1e5 Pa, ν = 0.3, spacing
/// 0.025 m, no gravity, no contact) at `dt_fraction` of its stable bound, its phyxels
/// stretched by [`FREE_STRETCH`] about the centre of mass, at rest.
fn stretched_free_sphere(dt_fraction: f32, backend: &str) -> Result<World, String> {
    let mut scene = builtin("falling-sphere");
    scene.gravity = [0.0; 3];
    scene.objects[0].material.damping = 0.0;
    scene.objects[0].surfel_spacing = Some(0.0125);
    scene.objects[0].spacing = 0.025;
    let probe = build(&scene, &opts(backend))?;
    let bound = probe.stable_dt().0;
    let dt = dt_fraction * bound;
    let mut w = build(
        &scene,
        &BuildOptions {
            dt: Some(dt),
            ..opts(backend)
        },
    )?;
    let p = &mut w.objects[0].phyxels;
    let c = Vec3::from_array(p.centre_of_mass().map(|v| v as f32));
    for i in 0..p.len() {
        let x = p.rest.get(i);
        p.pos.set(i, c + Vec3::from(FREE_STRETCH) * (x - c));
    }
    Ok(w)
}

/// Closed-form elastic energy (J, f64) that `backend`'s energy model gives phyxels `p`
/// of material `m` under the homogeneous stretch `x ↦ diag(stretch) x` from their rest
/// positions; `None` for a backend without a closed form here.
///
/// - `mls`: `Σ_i v_i W` with `W = ½ ε:σ + ½ k_v (det F − 1)²`, `σ = λ tr ε I + 2μ ε`, and
///   `ε = ½(FᵀF − I)` (calibrated strain) or `FᵀF − I` (the paper's); the MLS gradient of
///   an affine field is exact at every phyxel (first-order consistency), so this is the
///   backend's energy up to f32 round-off.
/// - `lj`: the sum over bonds of `ε_b (u − 1)²`, `u = (r⁰/r)⁶`, `ε_b = k r⁰²/72`,
///   `k = 0.4 E a` (a the lattice spacing), r the bond's stretched length; the bonds are
///   the pairs closer than [`lj::BOND_RADIUS`](crate::backends::lj::BOND_RADIUS) `a` at
///   rest, found by brute force (the stretch only lengthens bonds, so the backend's
///   wall branch for compressed bonds never applies).
/// - `sph`: none. Its volumetric energy `½K(ρ/ρ⁰ − 1)² V` takes ρ from kernel sums over
///   the stretched neighbours, which a truncated kernel at the free surface does not
///   give as `ρ⁰/det F` (with `ρ/ρ⁰ = 1/det F` and the exact shear term `μ |dev ε|² V`
///   the closed form came out 11.8% above the reported energy of this sphere).
pub fn stretch_energy(backend: &str, p: &Phyxels, m: &Material, stretch: DVec3) -> Option<f64> {
    let f = DMat3::from_diagonal(stretch);
    let volume = |i: usize| p.volume[i] as f64;
    let rest = |i: usize| p.rest.get(i).as_dvec3();
    match backend {
        "mls" => {
            let (lambda, mu) = (m.lame().0 as f64, m.lame().1 as f64);
            let c = f.transpose() * f - DMat3::IDENTITY;
            let eps = if m.strain == crate::body::material::StrainForm::Paper {
                c
            } else {
                c * 0.5
            };
            let tr = eps.x_axis.x + eps.y_axis.y + eps.z_axis.z;
            let sigma = DMat3::from_diagonal(DVec3::splat(lambda * tr)) + eps * (2.0 * mu);
            let dot: f64 = (0..3).map(|c| eps.col(c).dot(sigma.col(c))).sum();
            let dv = f.determinant() - 1.0;
            let w = 0.5 * dot + 0.5 * m.k_volume() as f64 * dv * dv;
            Some(w * (0..p.len()).map(volume).sum::<f64>())
        }
        "lj" => {
            let a = (0..p.len()).map(volume).fold(0.0, f64::max).cbrt();
            let k = crate::backends::lj::BOND_STIFFNESS as f64 * m.young as f64 * a;
            let radius = crate::backends::lj::BOND_RADIUS as f64 * a;
            let mut e = 0.0;
            for i in 0..p.len() {
                for j in i + 1..p.len() {
                    let d = rest(j) - rest(i);
                    let r0 = d.length();
                    if r0 > 0.0 && r0 < radius {
                        let u = (r0 / (f * d).length()).powi(6);
                        e += k * r0 * r0 / 72.0 * (u - 1.0) * (u - 1.0);
                    }
                }
            }
            Some(e)
        }
        _ => None,
    }
}

/// The elastic energy (J) `backend` reports for the free sphere of [`free_energy`] in
/// its initial state, stretched by [`FREE_STRETCH`] (the report after the first step,
/// which is that of the positions before it), and [`stretch_energy`]'s closed form for
/// it; `None` for a backend without a closed form or without an energy report.
pub fn initial_energy(backend: &str) -> Result<Option<(f64, f64, RunInfo)>, String> {
    let mut w = stretched_free_sphere(0.9, backend)?;
    let o = &w.objects[0];
    let Some(reference) = stretch_energy(
        backend,
        &o.phyxels,
        &o.material,
        Vec3::from(FREE_STRETCH).as_dvec3(),
    ) else {
        return Ok(None);
    };
    let info = timed(&mut w, 1, |_| true);
    let o = &w.objects[0];
    let reported = o
        .dynamics
        .diagnostics(&o.phyxels, &o.material)
        .elastic_energy;
    Ok(reported.map(|e| (e, reference, info)))
}

/// Energy (kinetic + elastic, J) of a free undamped sphere (R = 0.1 m, E = 1e5 Pa,
/// spacing 0.025 m, no gravity, no contact) released from a uniform 2% stretch along x
/// ([`FREE_STRETCH`]), run for `time` s at `dt_fraction` of the stable bound: the mean
/// energy over the last fifth of the run and over the first fifth (each spanning
/// several vibrations).
pub fn free_energy(
    dt_fraction: f32,
    time: f32,
    backend: &str,
) -> Result<(f64, f64, RunInfo), String> {
    let mut w = stretched_free_sphere(dt_fraction, backend)?;
    let dt = w.dt;
    let energy = |w: &World| {
        let o = &w.objects[0];
        o.phyxels.kinetic_energy()
            + o.dynamics
                .diagnostics(&o.phyxels, &o.material)
                .elastic_energy
                .unwrap_or(f64::NAN)
    };
    // The backend's elastic energy is that of its last step's gradient (positions before
    // the step) and the kinetic energy that after it: the pair oscillates by O(dt) about
    // the conserved value within each vibration, so compare window means.
    let mut series = Vec::new();
    let info = timed(&mut w, (time / dt) as usize, |w| {
        let e = energy(w);
        series.push(e);
        e.is_finite()
    });
    let k = (series.len() / 5).max(1);
    let mean = |s: &[f64]| s.iter().sum::<f64>() / s.len().max(1) as f64;
    Ok((mean(&series[series.len() - k..]), mean(&series[..k]), info))
}

/// Momentum rows: drift below 1e-4 of one sphere's momentum (Newton's third law,
/// Keiser et al. eqs. 6 and 8), at three spacings.
pub fn case_momentum(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    let spacings: &[f32] = if quick {
        &[0.04, 1.0 / 30.0, 0.03]
    } else {
        &[1.0 / 30.0, 0.025, 0.02]
    };
    sweep("momentum-collision", backend, 1e-4, spacings, |s| {
        let (worst, scale, touched, run) = collision_momentum(s, backend)?;
        Ok(Point {
            measured: worst,
            reference: 0.0,
            run,
            note: format!("spacing {s:.4} m, collided: {touched}"),
            // No collision, no test: NaN fails the row.
            rel_error: Some(if touched { worst / scale } else { f64::NAN }),
        })
    })
}

/// The free body's time steps (fractions of the stable bound), each with its tolerance
/// (relative departure of the energy) for MLS and for LJ: 2–3 × the largest error
/// measured over the quick (0.2 s) and full (0.5 s) runs, which agreed within 1% of each
/// error on an AVX2+FMA and a baseline x86-64 build (a free body has no contact to amplify
/// rounding). MLS 1.98%, 0.73%, 0.20% (its 0.9 row keeps the earlier 3%); LJ 0.29%,
/// 0.16%, 0.087%. The departure is larger in the quick runs (fifths of 0.04 s instead
/// of 0.1 s).
pub const ENERGY_ROWS: [(f32, f64, f64); 3] = [
    (0.9, 0.03, 0.006),
    (0.45, 0.015, 0.004),
    (0.225, 0.005, 0.002),
];

/// Tolerance of the `energy-free-body` row of `backend` at `dt_fraction` (one of
/// [`ENERGY_ROWS`]; the MLS column for any backend but `lj`).
pub fn energy_tolerance(backend: &str, dt_fraction: f32) -> f64 {
    let (_, mls, lj) = ENERGY_ROWS
        .iter()
        .copied()
        .find(|r| r.0 == dt_fraction)
        .unwrap_or((dt_fraction, 0.03, 0.03));
    if backend == "lj" { lj } else { mls }
}

/// Energy rows: symplectic Euler conserves a modified energy; the departure falls with
/// dt (the knob: 0.9, 0.45 and 0.225 × the stable bound), within [`energy_tolerance`].
/// The rows compare the energy with itself, so a scale error in the reported energy
/// cannot show here: `energy-initial` checks the scale. Not applicable (no rows) to a
/// backend that reports no elastic energy.
pub fn case_energy(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    let probe = build(&builtin("falling-sphere"), &opts(backend))?;
    let o = &probe.objects[0];
    if o.dynamics
        .diagnostics(&o.phyxels, &o.material)
        .elastic_energy
        .is_none()
    {
        return Ok(Vec::new());
    }
    let time = if quick { 0.2 } else { 0.5 };
    let fractions = ENERGY_ROWS.map(|r| r.0);
    sweep_by(
        "energy-free-body",
        backend,
        |frac| energy_tolerance(backend, frac),
        &fractions,
        |frac| {
            let (last, first, run) = free_energy(frac, time, backend)?;
            Ok(Point {
                measured: last,
                reference: first,
                run,
                note: format!("dt = {frac} × stable bound, {time} s"),
                rel_error: None,
            })
        },
    )
}

/// Initial-energy row: the elastic energy the backend reports for the stretched free
/// sphere against [`stretch_energy`]'s closed form (the energy-free-body rows compare the
/// energy with itself, so they cannot see a scale error in it). Tolerance: MLS 1e-6, LJ
/// 1.5e-5 (relative), about 3 × the measured f32 round-off: MLS 3.7e-7 (AVX2+FMA build)
/// and 2.9e-7 (baseline x86-64), LJ 5.7e-6 on both (f32 positions: half an ulp at 0.1 m
/// is 7e-6 of a bond's 0.5 mm elongation). MLS's energy density with `½ ε:σ` doubled (a
/// mutation check) fails by 93%. No rows for a backend without a
/// closed form or an energy report. One row: the stretched state does not depend on the
/// suite's knobs.
pub fn case_energy_initial(backend: &str, _quick: bool) -> Result<Vec<Row>, String> {
    let Some((e, reference, run)) = initial_energy(backend)? else {
        return Ok(Vec::new());
    };
    let mut r = row("energy-initial", backend, run, e, reference);
    r.note = "sphere R 0.1 m, spacing 0.025 m, 2% stretch along x".into();
    let tolerance = if backend == "lj" { 1.5e-5 } else { 1e-6 };
    Ok(vec![judged(r, tolerance)])
}

// ---------------------------------------------------------------------------------------
// Newton's cradle

/// The `newtons-cradle` at phyxel spacing `spacing` (surfel spacing `spacing / 3`): the
/// last sphere's momentum after `time` s and the incoming momentum (kg·m/s).
pub fn cradle(spacing: f32, time: f32, backend: &str) -> Result<(f64, f64, RunInfo), String> {
    let mut scene = builtin("newtons-cradle");
    for o in scene.objects.iter_mut() {
        o.spacing = spacing;
        o.surfel_spacing = Some(spacing / 3.0);
    }
    let mut w = build(&scene, &opts(backend))?;
    let p_in = w.objects[0].phyxels.momentum()[0];
    let steps = (time / w.dt) as usize;
    let info = timed(&mut w, steps, |_| true);
    Ok((w.objects[4].phyxels.momentum()[0], p_in, info))
}

/// The cradle's phyxel spacings (m) with their tolerances (relative error of the last
/// sphere's momentum): the quick suite runs the first three, the full suite the last
/// three. The error is the momentum the elastic spheres keep in the row; it falls with
/// the spacing on every backend, so each spacing gets its own bound, 2.2–2.5 × the
/// largest error measured there over the backends and over an AVX2+FMA and a baseline
/// x86-64 build (which agreed to 0.05 point): 25 mm 12.5–13.5%, 20 mm 8.5–9.9%,
/// 16.7 mm 7.0–8.4%, 12.5 mm 5.7–6.5% (MLS lowest). Mutation checks: a penalty damping
/// quadrupled in the contact force fails at 25 mm (34%); doubled, it passes (21%, 13%,
/// 11% for MLS in the quick suite): the cradle is not sensitive to a damping error of
/// that size.
pub const CRADLE_ROWS: [(f32, f64); 4] = [
    (0.025, 0.30),
    (0.02, 0.25),
    (1.0 / 60.0, 0.20),
    (0.0125, 0.15),
];

/// Newton's cradle rows: the last sphere carries the incoming momentum within the
/// tolerance of [`CRADLE_ROWS`] (the ideal rigid cradle hands all of it down; elastic
/// spheres keep some in the row).
pub fn case_cradle(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    let rows = if quick {
        &CRADLE_ROWS[..3]
    } else {
        &CRADLE_ROWS[1..]
    };
    let spacings: Vec<f32> = rows.iter().map(|r| r.0).collect();
    let tolerance = |s: f32| rows.iter().find(|r| r.0 == s).map_or(0.0, |r| r.1);
    sweep_by("newtons-cradle", backend, tolerance, &spacings, |s| {
        let (p, p_in, run) = cradle(s, 0.3, backend)?;
        Ok(Point {
            measured: p,
            reference: p_in,
            run,
            note: format!("spacing {s:.4} m, after 0.3 s"),
            rel_error: None,
        })
    })
}

// ---------------------------------------------------------------------------------------
// The suite

/// A case's runner: (backend, quick) → rows.
pub type CaseFn = fn(&str, bool) -> Result<Vec<Row>, String>;

/// The runners, each with the case names it produces.
pub const RUNNERS: &[(&[&str], CaseFn)] = &[
    (&["mls-consistency"], case_mls_consistency),
    (
        &["cantilever-deflection", "cantilever-frequency"],
        case_cantilever,
    ),
    (&["hertz-indentation", "hertz-exponent"], case_hertz),
    (&["hertz-impact"], case_hertz_impact),
    (&["incline-stick", "incline-slide"], case_incline),
    (&["momentum-collision"], case_momentum),
    (&["energy-free-body"], case_energy),
    (&["energy-initial"], case_energy_initial),
    (&["newtons-cradle"], case_cradle),
];

/// Checks a `--backend` value: one of [`backends::NAMES`].
pub fn check_backend(name: &str) -> Result<(), String> {
    if backends::NAMES.contains(&name) {
        Ok(())
    } else {
        Err(format!(
            "--backend {name}: unknown backend (available: {})",
            backends::NAMES.join(", ")
        ))
    }
}

/// `list`, or every backend of [`backends::NAMES`] when it is empty.
fn backend_names(list: &[String]) -> Vec<String> {
    if list.is_empty() {
        backends::NAMES.iter().map(|s| s.to_string()).collect()
    } else {
        list.to_vec()
    }
}

/// Runs every accuracy case for each of `backends_to_run` (all of [`backends::NAMES`]
/// when empty), calling `progress(label)` before each runner. Errors (a build refused,
/// no oscillation found) become failing rows that carry the message.
pub fn run_accuracy(
    backends_to_run: &[String],
    quick: bool,
    only: Option<&str>,
    mut progress: impl FnMut(&str),
) -> Vec<Row> {
    let names = backend_names(backends_to_run);
    let mut rows = Vec::new();
    for b in &names {
        for (cases, run) in RUNNERS {
            if !cases
                .iter()
                .any(|c| applies(c, b) && only.is_none_or(|o| c.starts_with(o)))
            {
                continue;
            }
            progress(&format!("{} ({b})", cases.join(", ")));
            match run(b, quick) {
                // A runner measures several cases at once: keep the ones asked for.
                Ok(r) => rows.extend(
                    r.into_iter()
                        .filter(|row| only.is_none_or(|o| row.case.starts_with(o))),
                ),
                Err(e) => rows.push(Row {
                    case: cases[0].into(),
                    group: "accuracy".into(),
                    backend: b.clone(),
                    phyxels: 0,
                    surfels: 0,
                    dt: 0.0,
                    seconds_per_step: 0.0,
                    measured: f64::NAN,
                    reference: f64::NAN,
                    rel_error: f64::NAN,
                    tolerance: 0.0,
                    pass: false,
                    status: "fail".into(),
                    note: e,
                }),
            }
        }
    }
    rows
}

/// For each resolution-driven case (see [`CASES`]) and backend, whether the error falls
/// from the coarsest (first) to the finest (last) row: `(case, backend, first, last)`.
pub fn convergence(rows: &[Row]) -> Vec<(String, String, f64, f64)> {
    let mut out = Vec::new();
    for (case, _, driven) in CASES {
        if !driven {
            continue;
        }
        let mut backends: Vec<&str> = rows
            .iter()
            .filter(|r| r.case == *case)
            .map(|r| r.backend.as_str())
            .collect();
        backends.sort_unstable();
        backends.dedup();
        for b in backends {
            let errs: Vec<f64> = rows
                .iter()
                .filter(|r| r.case == *case && r.backend == b)
                .map(|r| r.rel_error)
                .collect();
            if errs.len() >= 2 {
                out.push((
                    case.to_string(),
                    b.to_string(),
                    errs[0],
                    errs[errs.len() - 1],
                ));
            }
        }
    }
    out
}

/// The rows as a fixed-width table.
pub fn table(rows: &[Row]) -> String {
    let mut s = format!(
        "{:<22} {:<7} {:>7} {:>7} {:>9} {:>10} {:>12} {:>12} {:>9} {:>9} {:<8} {}\n",
        "case",
        "backend",
        "phyxels",
        "surfels",
        "dt (s)",
        "s/step",
        "measured",
        "reference",
        "rel.err",
        "tol",
        "status",
        "note"
    );
    for r in rows {
        s += &format!(
            "{:<22} {:<7} {:>7} {:>7} {:>9.2e} {:>10.3e} {:>12.5e} {:>12.5e} {:>9.2e} {:>9.1e} {:<8} {}\n",
            r.case,
            r.backend,
            r.phyxels,
            r.surfels,
            r.dt,
            r.seconds_per_step,
            r.measured,
            r.reference,
            r.rel_error,
            r.tolerance,
            r.status,
            r.note
        );
    }
    s
}

// ---------------------------------------------------------------------------------------
// Stability: hard cases, run or refused

/// How a hard case ended.
fn stability_row(
    case: &str,
    backend: &str,
    run: RunInfo,
    status: &str,
    pen: f64,
    bound: f64,
    note: String,
) -> Row {
    let pass = status == "stable" || status == "refused";
    Row {
        case: case.into(),
        group: "stability".into(),
        backend: backend.into(),
        phyxels: run.phyxels,
        surfels: run.surfels,
        dt: run.dt,
        seconds_per_step: run.seconds_per_step,
        measured: pen,
        reference: bound,
        rel_error: if bound > 0.0 { pen / bound } else { f64::NAN },
        tolerance: 1.0,
        pass,
        status: status.into(),
        note,
    }
}

/// Runs `world` for `time` s and judges it: stable when every value stays finite, the
/// deepest penetration stays below `bound` (m) and `extra(world)` holds (a reason when
/// not). Measured: the deepest penetration (m); reference: `bound`.
fn run_hard(
    case: &str,
    backend: &str,
    mut w: World,
    time: f32,
    bound: f64,
    extra: impl Fn(&World) -> Result<(), String>,
) -> Row {
    let steps = (time / w.dt) as usize;
    let mut finite = true;
    let mut at = 0;
    let info = timed(&mut w, steps, |w| {
        at += 1;
        finite = w.all_finite();
        finite
    });
    let pen = w.record.max_penetration as f64;
    let (status, note) = if !finite {
        let first = w
            .non_finite
            .as_ref()
            .map_or(String::new(), |e| format!(" ({e})"));
        (
            "unstable",
            format!("non-finite state after {at} steps{first}"),
        )
    } else if pen.is_nan() || pen >= bound {
        (
            "unstable",
            format!("penetration {pen:.3e} m beyond the bound {bound:.3e} m"),
        )
    } else {
        match extra(&w) {
            Ok(()) => (
                "stable",
                format!("{steps} steps ({time} s): finite, penetration bounded"),
            ),
            Err(e) => ("unstable", e),
        }
    };
    stability_row(case, backend, info, status, pen, bound, note)
}

fn hard_error(case: &str, backend: &str, e: String) -> Row {
    stability_row(
        case,
        backend,
        RunInfo::default(),
        "unstable",
        f64::NAN,
        f64::NAN,
        e,
    )
}

/// The hard cases for `backend`; `quick` shortens the runs.
///
/// - `stiff-material`: a sphere of E = 1e9 Pa (1e4 × the default) hitting a plane of
///   the same stiffness at 1 m/s, at the default (stable) dt;
/// - `dt-at-bound`: `sphere-on-plane` at exactly the stable bound;
/// - `dt-above-bound`: the same at 2× the bound: must be refused up front (the message
///   names the bound and the remedy);
/// - `high-speed-impact`: two spheres closing at 12 m/s, each surfel moving more than a
///   surfel spacing per step: must not tunnel (they end up apart in their original order);
/// - `deep-penetration`: `soft-on-plane` (the paper's Fig. 3 soft sphere);
/// - `one-phyxel-plate`: a plate one phyxel thick (rank-2 moment matrices) dropped on a plane.
///
/// Penetration bounds: the sphere radius for deep penetration, 10% of it elsewhere, the
/// plate thickness for the plate.
pub fn stability(
    backend: &str,
    quick: bool,
    only: Option<&str>,
    mut progress: impl FnMut(&str),
) -> Vec<Row> {
    let o = opts(backend);
    let want = |c: &str| only.is_none_or(|o| c.starts_with(o) || "stability".starts_with(o));
    let mut rows = Vec::new();
    let scale = if quick { 0.5 } else { 1.0 };

    // Very stiff material.
    if want("stiff-material") {
        progress(&format!("stiff-material ({backend})"));
        let mut s = builtin("sphere-on-plane");
        for obj in s.objects.iter_mut() {
            obj.material.young = 1.0e9;
            // The default, resolution-scaled damping: the scene's fixed 1 ms Kelvin–Voigt
            // time would be heavily overdamped at this stiffness and shrink the stable dt
            // by another factor of 100.
            obj.material.damping = -1.0;
        }
        s.objects[1].position = [0.0, 0.101, 0.0];
        s.objects[1].velocity = [0.0, -1.0, 0.0];
        rows.push(match build(&s, &o) {
            Ok(w) => run_hard("stiff-material", backend, w, 0.004, 0.01, |w| {
                let v = w.objects[1].phyxels.momentum()[1];
                if v > 0.0 {
                    Ok(())
                } else {
                    Err("did not bounce within 4 ms".into())
                }
            }),
            Err(e) => hard_error("stiff-material", backend, e),
        });
    }

    // dt at and above the stable bound.
    if want("dt-at-bound") || want("dt-above-bound") {
        progress(&format!("dt-at-bound, dt-above-bound ({backend})"));
        let s = builtin("sphere-on-plane");
        let bound = build(&s, &o).map(|w| w.stable_dt().0);
        match bound {
            Ok(bound) => {
                let at = BuildOptions {
                    dt: Some(bound),
                    ..o.clone()
                };
                if want("dt-at-bound") {
                    rows.push(match build(&s, &at) {
                        Ok(w) => run_hard("dt-at-bound", backend, w, 0.3 * scale, 0.01, |_| Ok(())),
                        Err(e) => hard_error("dt-at-bound", backend, e),
                    });
                }
                let above = BuildOptions {
                    dt: Some(2.0 * bound),
                    ..o.clone()
                };
                if want("dt-above-bound") {
                    rows.push(match build(&s, &above) {
                Err(e) if e.contains("stable bound") => {
                    let mut r = stability_row(
                        "dt-above-bound",
                        backend,
                        RunInfo {
                            dt: 2.0 * bound,
                            ..Default::default()
                        },
                        "refused",
                        f64::NAN,
                        f64::NAN,
                        e,
                    );
                    // Show the refusal is needed: forced, the run blows up.
                    let forced = BuildOptions {
                        allow_unstable: true,
                        ..above
                    };
                    if let Ok(mut w) = build(&s, &forced) {
                        let mut n = 0;
                        timed(&mut w, 2000, |w| {
                            n += 1;
                            w.all_finite()
                        });
                        if let Some(e) = &w.non_finite {
                            r.note += &format!(" [forced with --allow-unstable: {e}]");
                        } else if !w.all_finite() {
                            r.note += &format!(" [forced with --allow-unstable: non-finite after {n} steps]");
                        } else {
                            r.note += " [forced with --allow-unstable: still finite after 2000 steps]";
                        }
                    }
                    r
                }
                Err(e) => hard_error("dt-above-bound", backend, format!("refused without naming the bound: {e}")),
                Ok(_) => hard_error("dt-above-bound", backend, "dt = 2× the stable bound was accepted".into()),
            });
                }
            }
            Err(e) => rows.push(hard_error("dt-at-bound", backend, e)),
        }
    }

    // High-speed impact.
    if want("high-speed-impact") {
        progress(&format!("high-speed-impact ({backend})"));
        let mut s = builtin("two-spheres");
        for (k, obj) in s.objects.iter_mut().enumerate() {
            let side = if k == 0 { -1.0 } else { 1.0 };
            obj.velocity = [-side * 6.0, 0.0, 0.0];
            if quick {
                // Coarser phyxels: a longer stable step (more motion per step), fewer surfels.
                obj.spacing = 0.04;
                obj.surfel_spacing = Some(0.005);
            }
            obj.position = [side * 0.11, 0.0, 0.0];
        }
        rows.push(match build(&s, &o) {
            Ok(w) => {
                let per_step = 6.0 * w.dt;
                let spacing = w.objects[0].surfel_spacing;
                let mut r = run_hard("high-speed-impact", backend, w, 0.08, 0.1, |w| {
                    let (a, b) = (com(w, 0), com(w, 1));
                    let va = w.objects[0].phyxels.momentum()[0];
                    if a.x < b.x && va < 0.0 {
                        Ok(())
                    } else {
                        Err(format!(
                            "tunnelled: centres at x = {:.3}, {:.3} m",
                            a.x, b.x
                        ))
                    }
                });
                r.note += &format!(
                    "; surfels move {:.1} mm per step, {:.1} surfel spacings",
                    1e3 * per_step,
                    per_step / spacing
                );
                r
            }
            Err(e) => hard_error("high-speed-impact", backend, e),
        });
    }

    // Deep penetration: the soft sphere.
    if want("deep-penetration") {
        progress(&format!("deep-penetration ({backend})"));
        let mut s = builtin("soft-on-plane");
        if quick {
            // Coarser surfels (1 cm instead of 5 mm): the plane's surfels set the cost.
            for obj in s.objects.iter_mut() {
                obj.surfel_spacing = Some(0.01);
            }
        }
        rows.push(match build(&s, &o) {
            Ok(w) => run_hard("deep-penetration", backend, w, 1.0 * scale, 0.1, |w| {
                let y = com(w, 1).y;
                if y > 0.0 {
                    Ok(())
                } else {
                    Err(format!("fell through: centre at y = {y:.3} m"))
                }
            }),
            Err(e) => hard_error("deep-penetration", backend, e),
        });
    }

    // Degenerate sampling: a one-phyxel-thick plate.
    if want("one-phyxel-plate") {
        progress(&format!("one-phyxel-plate ({backend})"));
        let mut s = builtin("sphere-on-plane");
        s.objects[1].shape = Shape::Box {
            size: [0.3, 0.025, 0.3],
        };
        s.objects[1].spacing = 0.025;
        s.objects[1].rotation = [0.0; 3];
        s.objects[1].position = [0.0, 0.03, 0.0];
        rows.push(match build(&s, &o) {
            Ok(w) => {
                let n = w.objects[1].phyxels.len();
                let mut r = run_hard("one-phyxel-plate", backend, w, 0.3 * scale, 0.025, |w| {
                    let y = com(w, 1).y;
                    if y > 0.0 {
                        Ok(())
                    } else {
                        Err(format!("fell through: centre at y = {y:.3} m"))
                    }
                });
                r.note += &format!("; {n} phyxels in one layer");
                r
            }
            Err(e) => hard_error("one-phyxel-plate", backend, e),
        });
    }
    rows
}

/// [`stability`] for each backend (all when `backends_to_run` is empty).
pub fn run_stability(
    backends_to_run: &[String],
    quick: bool,
    only: Option<&str>,
    mut progress: impl FnMut(&str),
) -> Vec<Row> {
    let mut names = backend_names(backends_to_run);
    if quick && backends_to_run.is_empty() {
        // Quick: the hard cases on the default backend only (the full suite runs them
        // for every backend); `--backend NAME` picks another.
        names.truncate(1);
    }
    let mut rows = Vec::new();
    for b in &names {
        rows.extend(stability(b, quick, only, &mut progress));
    }
    rows
}

// ---------------------------------------------------------------------------------------
// Charts

/// Registers a system sans-serif TTF with plotters' text renderer (once); false when
/// none is found.
#[cfg(feature = "plots")]
fn register_font() -> bool {
    use std::sync::OnceLock;
    static FOUND: OnceLock<bool> = OnceLock::new();
    *FOUND.get_or_init(|| {
        let candidates = [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/TTF/DejaVuSans.ttf",
            "/usr/share/fonts/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
            "/Library/Fonts/Arial.ttf",
            "C:\\Windows\\Fonts\\arial.ttf",
        ];
        for c in candidates {
            if let Ok(bytes) = std::fs::read(c) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font(
                    "sans-serif",
                    plotters::style::FontStyle::Normal,
                    bytes,
                )
                .is_ok()
                {
                    return true;
                }
            }
        }
        false
    })
}

/// [`plot`] in a build without the `plots` feature: writes nothing, returns an error.
#[cfg(not(feature = "plots"))]
pub fn plot(_rows: &[Row], dir: &std::path::Path) -> Result<Vec<String>, String> {
    Err(format!(
        "{}: no charts: phyxel was built without the `plots` feature (enable it in Cargo.toml)",
        dir.display()
    ))
}

/// One chart per case of the accuracy rows: seconds per step (x, log) against relative
/// error (y, log), one series per backend, the tolerance as a dashed line; written as
/// `DIR/CASE.svg` and `DIR/CASE.png`. Returns notes (e.g. no font found: SVG only).
/// In a build without the `plots` feature it writes nothing and returns an error.
#[cfg(feature = "plots")]
pub fn plot(rows: &[Row], dir: &std::path::Path) -> Result<Vec<String>, String> {
    let font = register_font();
    let mut notes = Vec::new();
    if !font {
        notes.push("no system TTF font found (DejaVuSans.ttf): charts written as SVG only".into());
    }
    let mut cases: Vec<&str> = Vec::new();
    for r in rows.iter().filter(|r| r.group == "accuracy") {
        if !cases.contains(&r.case.as_str()) {
            cases.push(&r.case);
        }
    }
    for case in cases {
        let sel: Vec<&Row> = rows
            .iter()
            .filter(|r| r.case == case && r.seconds_per_step > 0.0 && r.rel_error.is_finite())
            .collect();
        if sel.is_empty() {
            continue;
        }
        let svg = dir.join(format!("{case}.svg"));
        chart(
            plotters::prelude::SVGBackend::new(&svg, (800, 560)),
            case,
            &sel,
        )
        .map_err(|e| format!("{}: {e}", svg.display()))?;
        if font {
            let png = dir.join(format!("{case}.png"));
            chart(
                plotters::prelude::BitMapBackend::new(&png, (800, 560)),
                case,
                &sel,
            )
            .map_err(|e| format!("{}: {e}", png.display()))?;
        }
        notes.push(format!(
            "wrote {}",
            svg.with_extension("{svg,png}").display()
        ));
    }
    Ok(notes)
}

#[cfg(feature = "plots")]
fn chart<DB: plotters::prelude::DrawingBackend>(
    backend: DB,
    case: &str,
    rows: &[&Row],
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    use plotters::prelude::*;
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let floor = 1e-9;
    let ys = rows
        .iter()
        .map(|r| r.rel_error.max(floor))
        .chain(rows.iter().map(|r| r.tolerance.max(floor)));
    let (ymin, ymax) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    let xs = rows.iter().map(|r| r.seconds_per_step);
    let (xmin, xmax) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    let root = backend.into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let mut c = ChartBuilder::on(&root)
        .caption(format!("{case}: speed against error"), ("sans-serif", 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(
            (xmin / 1.5..xmax * 1.5).log_scale(),
            (ymin / 3.0..ymax * 3.0).log_scale(),
        )
        .map_err(e)?;
    c.configure_mesh()
        .x_desc("wall seconds per step")
        .y_desc("relative error")
        .x_label_formatter(&|x| format!("{x:.0e}"))
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(e)?;
    let tol = rows[0].tolerance.max(floor);
    c.draw_series(DashedLineSeries::new(
        [(xmin / 1.5, tol), (xmax * 1.5, tol)],
        6,
        4,
        RED.stroke_width(1),
    ))
    .map_err(e)?
    .label(format!("tolerance {}", rows[0].tolerance))
    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    let mut backends: Vec<&str> = rows.iter().map(|r| r.backend.as_str()).collect();
    backends.sort_unstable();
    backends.dedup();
    for (k, b) in backends.iter().enumerate() {
        let color = [BLUE, GREEN, MAGENTA, CYAN, BLACK][k % 5].to_rgba();
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.backend == *b)
            .map(|r| (r.seconds_per_step, r.rel_error.max(floor)))
            .collect();
        c.draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
            .map_err(e)?
            .label(*b)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        c.draw_series(pts.iter().map(|&p| Circle::new(p, 4, color.filled())))
            .map_err(e)?;
    }
    c.configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(e)?;
    root.present().map_err(e)?;
    Ok(())
}
