//! Elastic cases: the MLS gradient against an affine field, the cantilever against
//! Euler–Bernoulli, and the energy of a free vibrating body against conservation.

use super::*;

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

/// MLS consistency rows; tolerance 1e-4 (f32 arithmetic), as in tests/dynamics/mls.rs.
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
    cantilever_at(spacing, periods, backend, None)
}

/// The built-in `cantilever` at phyxel and surfel spacing `spacing` (m), its material
/// undamped if `undamped`.
fn cantilever_scene(spacing: f32, undamped: bool) -> Scene {
    let mut scene = builtin("cantilever");
    scene.objects[0].spacing = spacing;
    scene.objects[0].surfel_spacing = Some(spacing);
    if undamped {
        scene.objects[0].material.damping = 0.0;
    }
    scene
}

/// The free end of a cantilever (object 0, along +x, sagging along −y): the phyxels
/// within half a spacing of its largest rest x. Its deflection is what the validation,
/// the static test and the peers bench read.
#[derive(Clone, Debug)]
pub struct CantileverTip(Vec<usize>);

impl CantileverTip {
    /// The tip of `world`'s bar at phyxel `spacing` (m).
    pub fn of(world: &World, spacing: f32) -> Self {
        let bar = &world.objects[0].phyxels;
        let x_max = (0..bar.len())
            .map(|i| bar.rest.x[i])
            .fold(f32::MIN, f32::max);
        Self(
            (0..bar.len())
                .filter(|&i| bar.rest.x[i] > x_max - 0.5 * spacing)
                .collect(),
        )
    }

    /// Mean downward displacement of the tip's phyxels from rest (m).
    pub fn deflection(&self, w: &World) -> f64 {
        let p = &w.objects[0].phyxels;
        self.0
            .iter()
            .map(|&i| (p.rest.y[i] - p.pos.y[i]) as f64)
            .sum::<f64>()
            / self.0.len() as f64
    }
}

/// The cantilever's world on `backend` at `dt` (`None`: the scene's default), and its
/// tip.
fn cantilever_world(
    scene: &Scene,
    spacing: f32,
    backend: &str,
    dt: Option<f32>,
) -> Result<(World, CantileverTip), String> {
    let world = build(
        scene,
        &BuildOptions {
            dt,
            ..opts(backend)
        },
    )?;
    let tip = CantileverTip::of(&world, spacing);
    Ok((world, tip))
}

/// [`cantilever`] at time step `dt` (s; `None`: the scene's default).
pub fn cantilever_at(
    spacing: f32,
    periods: usize,
    backend: &str,
    dt: Option<f32>,
) -> Result<(f64, f64, RunInfo), String> {
    let scene = cantilever_scene(spacing, false);
    let (mut world, tip) = cantilever_world(&scene, spacing, backend, dt)?;
    let dt = world.dt as f64;
    // Maxima closer than a quarter of the beam's period are a higher mode's.
    let gap = (0.25 / (euler_bernoulli(&scene).1 * dt)).max(2.0) as usize;
    let mut series = Vec::new();
    let mut maxima: Vec<usize> = Vec::new();
    let mut finite = true;
    let info = timed(&mut world, 200_000, |w| {
        let d = tip.deflection(w);
        finite = d.is_finite();
        series.push(d);
        let k = series.len();
        if k >= 3 && series[k - 2] > series[k - 3] && series[k - 2] >= series[k - 1] {
            // A maximum of the fundamental (higher modes ride on it: keep only maxima
            // above the running mean, a quarter period or more after the start and
            // after the last one). 1.2 × the mean: backward Euler at 1/60 s reaches its
            // first maximum at 1.48 × the mean of six samples (the undamped rise, 2×).
            let mean = series.iter().sum::<f64>() / k as f64;
            let apart = maxima.last().map_or(k - 2 > gap, |&m| k - 2 - m > gap);
            if series[k - 2] > mean * 1.2 && apart {
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
        let m = maxima[0];
        let b = m + 1;
        let mean = series[..b].iter().sum::<f64>() / b as f64;
        // The peak between samples, from the parabola through the three around it: at
        // 1/60 s the half period is six steps, and a whole step is a 17% error.
        let (y0, y1, y2) = (series[m - 1], series[m], series[m + 1]);
        let curvature = y0 - 2.0 * y1 + y2;
        let shift = if curvature < 0.0 {
            (0.5 * (y0 - y2) / curvature).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        return Ok((mean, 2.0 * (b as f64 + shift) * dt, info));
    }
    let (a, b) = (maxima[0], maxima[periods]);
    let mean = series[a..b].iter().sum::<f64>() / (b - a) as f64;
    Ok((mean, (b - a) as f64 * dt / periods as f64, info))
}

/// Cantilever rows (3, 5, 7 phyxels through the thickness in quick mode; 5, 7, 9 in
/// full mode: odd counts put a layer of phyxels on the clamp's face at x = −0.45 m, so
/// the bar is held where Euler–Bernoulli's is; at even counts the face falls between
/// layers and the bar is held half a spacing deeper, +5% sag at 4 through): deflection
/// and frequency within [`cantilever_tolerance`] at every resolution (MLS: 5% and 5%),
/// both converging (docs/ACCURACY.md, "Cantilever", explains the error sources).
pub fn case_cantilever(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    let spacings: &[f32] = if quick {
        &[1.0 / 30.0, 0.02, 1.0 / 70.0]
    } else {
        &[0.02, 1.0 / 70.0, 1.0 / 90.0]
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
        // The implicit backend at 1 ms (its frame-rate default damps the swing these
        // rows average over within a period; the dt rows below take the large steps).
        let dt = (backend == crate::backends::mls::implicit::NAME)
            .then_some(crate::world::MAX_DEFAULT_DT);
        let (d, period, info) = cantilever_at(s, periods, backend, dt)?;
        let mut r = row("cantilever-deflection", backend, info, d, d_ref);
        r.note = format!("spacing {s:.4} m, {through} through the thickness");
        rows.push(judged(r, d_tol));
        let mut r = row("cantilever-frequency", backend, info, 1.0 / period, f_ref);
        r.note = format!("spacing {s:.4} m, {through} through the thickness");
        rows.push(judged(r, f_tol));
    }
    if backend == crate::backends::mls::implicit::NAME {
        rows.extend(implicit_dt_rows(quick)?);
    }
    Ok(rows)
}

/// The time steps (s) of the implicit backend's cantilever rows: up to a frame's.
pub const IMPLICIT_DTS: [f32; 3] = [1.0 / 240.0, 1.0 / 120.0, 1.0 / 60.0];

/// The implicit backend's cantilever at 4 phyxels through the thickness and the steps
/// of [`IMPLICIT_DTS`] (the first half period, as the quick suite measures). The
/// deflection keeps its reference: a step's size does not move the static shape. The
/// frequency's reference is backward Euler's own: an oscillator of angular
/// frequency ω stepped at dt turns by `atan(ω dt)` per step, so the period stretches by
/// `ω dt / atan(ω dt)` (11% at a 60th of a second for this beam); the row checks that
/// the backend is that integrator on the MLS beam, within the same tolerance.
fn implicit_dt_rows(_quick: bool) -> Result<Vec<Row>, String> {
    let backend = crate::backends::mls::implicit::NAME;
    let scene = builtin("cantilever");
    let (d_ref, f_ref) = euler_bernoulli(&scene);
    // At 4 through the clamp's face lies between layers and the bar is held half a
    // spacing deeper: its static sag is +5.8%, so these rows keep bounds of their own.
    let s = 0.025;
    let (d_tol, f_tol) = DT_ROW_TOLERANCES;
    let mut rows = Vec::new();
    for &dt in &IMPLICIT_DTS {
        let (d, period, info) = cantilever_at(s, 0, backend, Some(dt))?;
        let note = format!("spacing {s:.4} m, dt {dt:.5} s");
        let mut r = row("cantilever-dt-deflection", backend, info, d, d_ref);
        r.note = note.clone();
        rows.push(judged(r, d_tol));
        let w = 2.0 * std::f64::consts::PI * f_ref * dt as f64;
        let f_be = f_ref * w.atan() / w;
        let mut r = row("cantilever-dt-frequency", backend, info, 1.0 / period, f_be);
        r.note = format!("{note}; reference backward Euler's atan(ω dt)/(ω dt) × f₁");
        rows.push(judged(r, f_tol));
        let (decrement, info) = cantilever_damping(dt)?;
        let be = std::f64::consts::PI * (1.0 + w * w).ln() / w.atan();
        let mut r = row("cantilever-dt-damping", backend, info, decrement, be);
        r.note = format!(
            "{note}; decrement per period, {:.2} of the amplitude kept; reference π ln(1 + ω²dt²)/atan(ω dt)",
            (-decrement).exp()
        );
        rows.push(judged(r, DAMPING_TOLERANCE));
    }
    Ok(rows)
}

/// Tolerances `(deflection, frequency)` of the `cantilever-dt-*` rows (4 through the
/// thickness: measured +3.8 to +5.3% and −1.7 to +5.2%).
pub const DT_ROW_TOLERANCES: (f64, f64) = (0.15, 0.10);

/// Tolerance of `cantilever-dt-damping` (relative error of the decrement per period):
/// the decrement `π ln(1 + x²)/atan x` grows as `x = ω dt` to first order, and the MLS
/// bar's first mode is off Euler–Bernoulli's ω at 4 phyxels through the thickness (about
/// −3%: its static sag is +5.8%, the clamp held half a spacing deep), plus the extrema's
/// interpolation between samples (six per half period at 1/60 s): 15% (measured 7–8%).
pub const DAMPING_TOLERANCE: f64 = 0.15;

/// Backward Euler's damping of the built-in cantilever's first mode, undamped material,
/// at time step `dt` (spacing 2.5 cm): its decrement per period `−ln(A(t + T)/A(t))`,
/// from the bar's start at rest (straight: an extremum of its swing about the static
/// sag `d_s`), its first maximum `d₁` and the next minimum `d₂` (both interpolated
/// between samples). A swing that keeps `q` of its amplitude per half period gives
/// `d₁ = d_s (1 + q)` and `d₂ = d_s (1 − q²)`, so `q = 1 − d₂/d₁`, and the decrement is
/// `−2 ln q`.
pub fn cantilever_damping(dt: f32) -> Result<(f64, RunInfo), String> {
    let backend = crate::backends::mls::implicit::NAME;
    let spacing = 0.025;
    let scene = cantilever_scene(spacing, true);
    let period = 1.0 / euler_bernoulli(&scene).1;
    let (mut world, tip) = cantilever_world(&scene, spacing, backend, Some(dt))?;
    let mut series = vec![0.0f64];
    let steps = (1.5 * period / dt as f64).ceil() as usize;
    let info = timed(&mut world, steps, |w| {
        let d = tip.deflection(w);
        series.push(d);
        d.is_finite()
    });
    // The peak between samples, from the parabola through the three around it.
    let peak = |k: usize| {
        let (y0, y1, y2) = (series[k - 1], series[k], series[k + 1]);
        let curvature = y0 - 2.0 * y1 + y2;
        if curvature != 0.0 {
            let shift = (0.5 * (y0 - y2) / curvature).clamp(-0.5, 0.5);
            y1 - 0.25 * (y0 - y2) * shift
        } else {
            y1
        }
    };
    // Extrema of the fundamental: a quarter period or more apart (higher modes ride on
    // it at the finer steps).
    let gap = ((0.25 * period / dt as f64) as usize).max(1);
    let extremum = |from: usize, max: bool| {
        (from.max(1)..series.len() - 1).find(|&k| {
            let (a, b, c) = (series[k - 1], series[k], series[k + 1]);
            if max {
                b > a && b >= c
            } else {
                b < a && b <= c
            }
        })
    };
    let first = extremum(gap, true).ok_or("cantilever-dt-damping: no first maximum")?;
    let second =
        extremum(first + gap, false).ok_or("cantilever-dt-damping: no minimum after it")?;
    let (d1, d2) = (peak(first), peak(second));
    let q = 1.0 - d2 / d1;
    if !(q > 0.0 && q < 1.0) {
        return Err(format!(
            "cantilever-dt-damping: extrema {d1:.4e} and {d2:.4e} m give no decay"
        ));
    }
    Ok((-2.0 * q.ln(), info))
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
    // A backend without a stability bound (backward Euler) takes its fractions of the
    // largest default step instead.
    let bound = probe.stable_dt().0.min(crate::world::MAX_DEFAULT_DT);
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
///   the closed form is 11.8% above the reported energy of this sphere).
pub fn stretch_energy(backend: &str, p: &Phyxels, m: &Material, stretch: DVec3) -> Option<f64> {
    let f = DMat3::from_diagonal(stretch);
    let volume = |i: usize| p.volume[i] as f64;
    let rest = |i: usize| p.rest.get(i).as_dvec3();
    match backend {
        "mls" | "mls-implicit" => {
            let (lambda, mu) = (m.lame().0 as f64, m.lame().1 as f64);
            let c = f.transpose() * f - DMat3::IDENTITY;
            let eps = if m.strain == crate::material::StrainForm::Paper {
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
    // The explicit backends report the energy of the positions before their last step;
    // the implicit one that of the current positions (no step needed).
    let steps = if backend == crate::backends::mls::implicit::NAME {
        0
    } else {
        1
    };
    let info = timed(&mut w, steps, |_| true);
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

/// The free body's time steps (fractions of the stable bound), each with its tolerance
/// (relative departure of the energy) for MLS and for LJ: 2–3 × the largest error
/// measured over the quick (0.2 s) and full (0.5 s) runs, which agreed within 1% of each
/// error on an AVX2+FMA and a baseline x86-64 build (a free body has no contact to amplify
/// rounding). MLS 1.98%, 0.73%, 0.20% (its 0.9 row has 3%); LJ 0.29%,
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
    // Backward Euler dissipates: its energy may only fall (a gain above f32 noise, 1e-3,
    // fails); the decay is the row's error, and falls with dt.
    let dissipative = backend == crate::backends::mls::implicit::NAME;
    sweep_by(
        "energy-free-body",
        backend,
        |frac| {
            if dissipative {
                1.0
            } else {
                energy_tolerance(backend, frac)
            }
        },
        &fractions,
        |frac| {
            let (last, first, run) = free_energy(frac, time, backend)?;
            let change = last / first - 1.0;
            Ok(Point {
                measured: last,
                reference: first,
                run,
                note: if dissipative {
                    format!(
                        "dt = {frac} ms, {time} s: energy {:+.2}% (backward Euler may only lose)",
                        100.0 * change
                    )
                } else {
                    format!("dt = {frac} × stable bound, {time} s")
                },
                rel_error: dissipative.then(|| {
                    if change > 1e-3 {
                        f64::INFINITY
                    } else {
                        -change
                    }
                }),
            })
        },
    )
}

/// Initial-energy row: the elastic energy the backend reports for the stretched free
/// sphere against [`stretch_energy`]'s closed form (the energy-free-body rows compare the
/// energy with itself, so they cannot see a scale error in it). Tolerance: MLS 3e-6, LJ
/// 1.5e-5 (relative), set by the f32 positions: half an ulp at 0.1 m is 3.7e-6 of a
/// phyxel's 2 mm displacement (7e-6 of an LJ bond's 0.5 mm elongation). Measured: MLS
/// 1.0e-6 (the strain computed as `g + gᵀ + gᵀg`: the f32 `J` of `JᵀJ − I` loses the
/// strain's digits at small strain), LJ 5.7e-6. MLS's energy density with `½ ε:σ`
/// doubled (a mutation check) fails by 93%. No rows for a backend without a closed form
/// or an energy report. One row: the stretched state does not depend on the suite's
/// knobs.
pub fn case_energy_initial(backend: &str, _quick: bool) -> Result<Vec<Row>, String> {
    let Some((e, reference, run)) = initial_energy(backend)? else {
        return Ok(Vec::new());
    };
    let mut r = row("energy-initial", backend, run, e, reference);
    r.note = "sphere R 0.1 m, spacing 0.025 m, 2% stretch along x".into();
    let tolerance = if backend == "lj" { 1.5e-5 } else { 3e-6 };
    Ok(vec![judged(r, tolerance)])
}
