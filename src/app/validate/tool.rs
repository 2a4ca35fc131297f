//! Displacement-controlled cases, the tool's view: a frictionless block squeezed by a
//! kinematic plate (the plate's force against its travel), and a block pushed sideways
//! by a kinematic tool until it slips (the break-away force against μN).

use super::*;
use crate::contact::ContactPoint;
use crate::dynamics::kinematic::Kinematic;

/// The nominal (first Piola–Kirchhoff) axial stress (Pa, negative in compression) of
/// `m`'s elastic law under uniaxial stress at axial stretch `stretch`, the lateral faces
/// free: the MLS backends' energy `s(λ/2 (tr ε)² + μ tr ε²) + k_v/2 (det F − 1)²` with
/// Green's strain ε (s = 1, or 4 for the paper's strain), `F = diag(t, stretch, t)` and
/// the lateral stretch t solving `∂W/∂t = 0` (bisection). At small strain this is
/// `E′ (stretch − 1)` with `E′` the Young's modulus of Lamé λ + k_v and μ (the volume
/// term stiffens it: 1.4% at the default k_v = 0.1 E, ν = 0.3).
pub fn uniaxial_stress(m: &Material, stretch: f64) -> f64 {
    let (lambda, mu) = m.lame();
    let (lambda, mu) = (lambda as f64, mu as f64);
    let s = if m.strain == crate::material::StrainForm::Paper {
        4.0
    } else {
        1.0
    };
    let kv = m.k_volume() as f64;
    let l = stretch;
    let ey = 0.5 * (l * l - 1.0);
    // Second Piola–Kirchhoff stress along an axis with Green strain `e`, and the
    // volume term's pressure-like factor.
    let s_axis = |t: f64, e: f64| {
        let tr = ey + 2.0 * 0.5 * (t * t - 1.0);
        s * (lambda * tr + 2.0 * mu * e)
    };
    let lateral = |t: f64| s_axis(t, 0.5 * (t * t - 1.0)) + kv * (l * t * t - 1.0) * l;
    let (mut lo, mut hi) = (0.5f64, 1.5f64);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if lateral(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let t = 0.5 * (lo + hi);
    l * s_axis(t, ey) + kv * (l * t * t - 1.0) * t * t
}

/// The world of a tool case's scene `text` (named `name`) on `backend`, at `dt` (None:
/// the backend's default step).
fn build_text(text: &str, name: &str, backend: &str, dt: Option<f32>) -> Result<World, String> {
    let mut scene = Scene::parse(text, name).map_err(|e| e.to_string())?;
    scene.dt = dt;
    build(&scene, &opts(backend))
}

/// What [`squeeze`] measured.
#[derive(Clone, Copy, Debug)]
pub struct Squeeze {
    /// The plate's force against its own travel (N/m), least squares over the window.
    pub tool_slope: f64,
    /// The plate's force against the cube's own shortening (N/m): the shortening
    /// between its top and bottom phyxel layers, scaled to the cube's height.
    pub body_slope: f64,
    /// The reference slope (N/m): the secant of [`uniaxial_stress`] × A over the
    /// cube's strains at the window's ends.
    pub reference: f64,
    /// The small-strain slope E·A/L (N/m).
    pub linear: f64,
    /// Largest penetration of the run (m).
    pub max_penetration: f64,
    pub run: RunInfo,
}

/// Phyxels along the block's edge at the three resolutions of a tool case.
fn across(quick: bool) -> &'static [u32] {
    if quick { &[4, 6, 8] } else { &[6, 8, 10] }
}

/// Edge of the squeezed cube (m).
pub const SQUEEZE_EDGE: f64 = 0.1;

/// A frictionless elastic cube (edge [`SQUEEZE_EDGE`], E = 1e5 Pa, ν = 0.3, `across`
/// phyxels along an edge), weightless, 0.1 mm above a static ground and 0.1 mm below a
/// kinematic plate moving down at 1 cm/s, the plate and ground at E = 1e9 Pa (rigid
/// parts). Over 0.4 s (4 mm of travel), the plate's reaction against its travel and
/// against the cube's shortening, fitted from 1.5 mm of travel on; `dt` None: the
/// backend's default step.
pub fn squeeze(across: u32, backend: &str, dt: Option<f32>) -> Result<Squeeze, String> {
    let edge = SQUEEZE_EDGE as f32;
    let spacing = edge / across as f32;
    let gap = 1e-4f32;
    let y_ground = -0.5 * edge - gap - 0.01;
    let y_plate = 0.5 * edge + gap + 0.01;
    let text = format!(
        r#"name = "squeeze"
gravity = [0.0, 0.0, 0.0]

[[objects]]
name = "ground"
static = true
shape = {{ type = "box", size = [0.2, 0.02, 0.2] }}
spacing = 0.01
position = [0.0, {y_ground}, 0.0]
material = {{ young = 1.0e9, poisson = 0.3 }}

[[objects]]
name = "cube"
shape = {{ type = "box", size = [{edge}, {edge}, {edge}] }}
spacing = {spacing}
material = {{ young = 1.0e5, poisson = 0.3 }}

[[objects]]
name = "plate"
backend = "kinematic"
shape = {{ type = "box", size = [0.16, 0.02, 0.16] }}
spacing = 0.01
position = [0.0, {y_plate}, 0.0]
velocity = [0.0, -0.01, 0.0]
material = {{ young = 1.0e9, poisson = 0.3 }}
"#
    );
    let mut w = build_text(&text, "squeeze", backend, dt)?;
    let material = w.objects[1].material.clone();
    let rest = &w.objects[1].phyxels.rest;
    let (lo, hi) = (0..rest.len())
        .map(|j| rest.get(j).y)
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), y| {
            (a.min(y), b.max(y))
        });
    let layer = |want: f32| -> Vec<usize> {
        (0..rest.len())
            .filter(|&j| (rest.get(j).y - want).abs() < 0.25 * spacing)
            .collect()
    };
    let (bottom, top) = (layer(lo), layer(hi));
    let h0 = (hi - lo) as f64;
    let mean_y = |w: &World, set: &[usize]| {
        let p = &w.objects[1].phyxels.pos;
        set.iter().map(|&j| p.get(j).y as f64).sum::<f64>() / set.len() as f64
    };
    let plate0 = w.objects[2].phyxels.centre_of_mass()[1];
    let steps = (0.4 / w.dt as f64).round() as usize;
    let mut pts: Vec<(f64, f64, f64)> = Vec::new();
    let info = timed(&mut w, steps, |w| {
        let travel = plate0 - w.objects[2].phyxels.centre_of_mass()[1];
        let shortening = 1.0 - (mean_y(w, &top) - mean_y(w, &bottom)) / h0;
        let force = w.objects[2]
            .dynamics_as::<Kinematic>()
            .map_or(0.0, |k| k.reaction().y as f64);
        pts.push((travel, shortening * SQUEEZE_EDGE, force));
        true
    });
    let window: Vec<&(f64, f64, f64)> = pts.iter().filter(|p| p.0 >= 1.5e-3).collect();
    if window.len() < 3 {
        return Err(format!(
            "squeeze: {} steps in the fitting window (dt {})",
            window.len(),
            info.dt
        ));
    }
    let max_penetration = w.record.max_penetration as f64;
    let tool_slope = slope(&window.iter().map(|p| (p.0, p.2)).collect::<Vec<_>>());
    let body_slope = slope(&window.iter().map(|p| (p.1, p.2)).collect::<Vec<_>>());
    let area = SQUEEZE_EDGE * SQUEEZE_EDGE;
    let force = |d: f64| -area * uniaxial_stress(&material, 1.0 - d / SQUEEZE_EDGE);
    let (d1, d2) = (window[0].1, window[window.len() - 1].1);
    let reference = (force(d2) - force(d1)) / (d2 - d1);
    Ok(Squeeze {
        tool_slope,
        body_slope,
        reference,
        linear: material.young as f64 * area / SQUEEZE_EDGE,
        max_penetration,
        run: info,
    })
}

/// Squeeze rows: the plate's force against its travel, at three resolutions, against
/// the continuum's uniaxial response of the same law ([`uniaxial_stress`]; over this
/// squeeze the law is 3.6–5% softer than E·A/L, so the small-strain slope is not the
/// reference). The note carries the cube's own slope (the body alone, whose error is
/// under 1.3% from 8 across) and E·A/L; the rest of the error is the two contact
/// layers' compliance, and falls with the spacing ([`squeeze_tolerance`]).
pub fn case_squeeze(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    sweep_by("squeeze", backend, squeeze_tolerance, across(quick), |n| {
        let s = squeeze(n, backend, None)?;
        Ok(Point {
            measured: s.tool_slope,
            reference: s.reference,
            run: s.run,
            note: format!(
                "{n} across; body alone {:.0} N/m ({:+.1}%); E·A/L {:.0} N/m; deepest overlap {:.2} mm",
                s.body_slope,
                100.0 * (s.body_slope / s.reference - 1.0),
                s.linear,
                1e3 * s.max_penetration
            ),
            rel_error: None,
        })
    })
}

/// Tolerance of `squeeze` at `across` phyxels along the edge (relative error of the
/// plate's slope): a regression bound about 1.25 times the error measured on both MLS
/// backends (33.3–33.7% at 4 across, 19.5–19.8% at 6, 9.9–10.1% at 8, 8.5% at 10),
/// all of it but the body's 0.3–1.2% in the contact layers (the plate's penalty
/// springs are softer than the cube near its faces). The aim, 3% at 10 across, is
/// docs/ACCURACY.md's known limit.
pub fn squeeze_tolerance(across: u32) -> f64 {
    match across {
        ..=4 => 0.42,
        5..=6 => 0.25,
        7..=8 => 0.13,
        _ => 0.11,
    }
}

/// What [`break_away`] measured.
#[derive(Clone, Copy, Debug)]
pub struct BreakAway {
    /// The tool's mean force along its motion over the run's last [`SLIDE_WINDOW`]
    /// seconds (N), while the block slides with it (checked): the force at which it
    /// breaks away and keeps sliding (Coulomb's law has one μ).
    pub sliding: f64,
    /// The tool's largest force before the block has moved 1 mm (N). An elastic block
    /// slips from its pushed edge on before it slides as a whole (partial slip), so this
    /// is below μ m g.
    pub peak: f64,
    /// μ m g (N).
    pub reference: f64,
    /// The ground's friction over its normal force on the block over the same
    /// interval (sums of the pair's totals): the friction law's own ratio, μ while every
    /// contact slides, below it while some stick.
    pub friction_ratio: f64,
    pub run: RunInfo,
}

/// The span at the end of a `break-away` run over which the sliding force is averaged
/// (s): from 0.35 s the block slides with the plate on both MLS backends. Earlier it
/// still slips in part: `mls-implicit`'s block has moved 1 mm by 0.225 s but keeps the
/// plate's speed only from about 0.29 s, and a window from 1 mm read 1.5–3.3% low.
pub const SLIDE_WINDOW: f64 = 0.2;

/// How far the block's mean speed over [`SLIDE_WINDOW`] may differ from the plate's
/// for it to count as sliding with it (fraction).
pub const SLIDE_SPEED_SHARE: f64 = 0.1;

/// A 0.1 m elastic block (E = 1e5 Pa, τ = 1 ms, `across` phyxels along an edge, 1 kg)
/// resting on a static ground (E = 1e9) with μ = 0.5 between them, pushed sideways at
/// 1 cm/s by a frictionless kinematic plate that starts 1 mm from it, over 0.55 s. The
/// material damping stops the block's bounce on the ground (docs/ACCURACY.md, "Known
/// limits": the contact dashpot does not).
pub fn break_away(across: u32, backend: &str, dt: Option<f32>) -> Result<BreakAway, String> {
    let edge = SQUEEZE_EDGE as f32;
    let spacing = edge / across as f32;
    let gap = 1e-4f32;
    let y_ground = -0.5 * edge - gap - 0.01;
    let x_pusher = -0.5 * edge - 1e-3 - 0.01;
    let plate_speed = 0.01f32;
    let text = format!(
        r#"name = "break-away"
gravity = [0.0, -9.81, 0.0]
sleep = false

[[objects]]
name = "ground"
static = true
shape = {{ type = "box", size = [0.4, 0.02, 0.2] }}
spacing = 0.01
position = [0.0, {y_ground}, 0.0]
material = {{ young = 1.0e9, poisson = 0.3, friction = 0.5 }}

[[objects]]
name = "block"
shape = {{ type = "box", size = [{edge}, {edge}, {edge}] }}
spacing = {spacing}
material = {{ young = 1.0e5, poisson = 0.3, friction = 0.5, damping = 1.0e-3 }}

[[objects]]
name = "pusher"
backend = "kinematic"
shape = {{ type = "box", size = [0.02, 0.06, 0.12] }}
spacing = 0.01
position = [{x_pusher}, 0.0, 0.0]
velocity = [{plate_speed}, 0.0, 0.0]
material = {{ young = 1.0e9, poisson = 0.3, friction = 0.0 }}
"#
    );
    let mut w = build_text(&text, "break-away", backend, dt)?;
    let mass = w.objects[1]
        .phyxels
        .mass
        .iter()
        .map(|&m| m as f64)
        .sum::<f64>();
    let x0 = com(&w, 1).x;
    let duration = 0.55;
    let steps = (duration / w.dt as f64).round() as usize;
    let (mut peak, mut sum, mut n) = (0.0f64, 0.0f64, 0usize);
    let (mut friction, mut normal) = (0.0f64, 0.0f64);
    // The block's (time, x) at the window's first and last steps.
    let (mut start, mut end) = (None, (0.0f64, 0.0f64));
    let info = timed(&mut w, steps, |w| {
        let moved = com(w, 1).x - x0;
        let force = w.objects[2]
            .dynamics_as::<Kinematic>()
            .map_or(0.0, |k| -k.reaction().x as f64);
        if moved < 1e-3 {
            peak = peak.max(force);
        }
        if w.time >= duration - SLIDE_WINDOW {
            sum += force;
            n += 1;
            end = (w.time, moved);
            start.get_or_insert(end);
            let ground = w.contact.patches.iter().position(|p| (p.a, p.b) == (0, 1));
            if let Some(t) = ground.map(|k| w.contact_totals().swap_remove(k)) {
                friction += t.friction_force[0].abs();
                normal += t.normal_force;
            }
        }
        true
    });
    let speed = match start {
        Some(start) if end.0 > start.0 => (end.1 - start.1) / (end.0 - start.0),
        _ => 0.0,
    };
    if (speed / plate_speed as f64 - 1.0).abs() > SLIDE_SPEED_SHARE {
        return Err(format!(
            "break-away: the block did not slide with the plate over the run's last {SLIDE_WINDOW} s \
             (its mean speed {speed:.4} m/s against the plate's {plate_speed}; dt {})",
            info.dt
        ));
    }
    Ok(BreakAway {
        peak,
        sliding: sum / n as f64,
        reference: 0.5 * mass * 9.81,
        friction_ratio: friction / normal.max(f64::MIN_POSITIVE),
        run: info,
    })
}

/// Break-away rows: the tool's force while the block slides with it against μ m g, at
/// three resolutions, within [`BREAK_AWAY_TOLERANCE`].
pub fn case_break_away(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    sweep(
        "break-away",
        backend,
        BREAK_AWAY_TOLERANCE,
        across(quick),
        |n| {
            let b = break_away(n, backend, None)?;
            Ok(Point {
                measured: b.sliding,
                reference: b.reference,
                run: b.run,
                note: format!(
                    "{n} across; largest before 1 mm of sliding {:.3} N; ground friction / normal {:.3}",
                    b.peak, b.friction_ratio
                ),
                rel_error: None,
            })
        },
    )
}

/// Tolerance of `break-away` (relative error of the sliding force): a regression bound
/// about 1.5 times the largest error measured. `mls` reads 3.0–4.8% low (4 to 10
/// across): the pushed block rocks at about 20 Hz as it slides, its normal force
/// swinging by a tenth, and its contacts stick in part of each cycle (the ground's
/// friction over its normal force 0.47–0.48); `mls-implicit` reads 0.2–0.3% high
/// (that ratio 0.500). The aim, 2%, is docs/ACCURACY.md's known limit.
pub const BREAK_AWAY_TOLERANCE: f64 = 0.075;

/// Radius of the indenting sphere (m).
pub const INDENT_RADIUS: f64 = 0.05;
/// Depth of the indentation at its end, a tenth of the sphere's radius (m).
pub const INDENT_DEPTH: f64 = 0.1 * INDENT_RADIUS;

/// Hertz's contact radius at the final depth, `√(R δ)` (m).
pub fn indent_contact_radius() -> f64 {
    (INDENT_RADIUS * INDENT_DEPTH).sqrt()
}

/// What [`indent`] measured at the final depth.
#[derive(Clone, Copy, Debug)]
pub struct Indent {
    /// The sphere's force on the block (N).
    pub force: f64,
    /// Hertz's `4/3 E* √R δ^{3/2}` (N), `E* = E / (1 − ν²)` (the sphere rigid).
    pub hertz: f64,
    /// Patch radius from the second moment of the normal force (m), and Hertz's `√(R δ)`.
    pub radius: f64,
    pub hertz_radius: f64,
    pub run: RunInfo,
}

/// A rigid sphere (radius [`INDENT_RADIUS`], E = 1e9 Pa, kinematic) pressed at 1 cm/s
/// into a frictionless weightless block (E = 1e5 Pa, ν = 0.3) whose bottom layer is
/// held, from 0.1 mm above it to [`INDENT_DEPTH`] into it, with the block's spacing
/// `contact radius / per_contact` ([`indent_contact_radius`]). The block is 0.14 m
/// wide and 0.08 m deep (9 and 5 contact radii; the held bottom stiffens it against
/// Hertz's half-space a little), its influence radius 3 spacings: at the default 2 the
/// phyxels under the sphere run away from 2.5 per contact radius on (docs/ACCURACY.md,
/// "Known limits").
pub fn indent(per_contact: f64, backend: &str, dt: Option<f32>) -> Result<Indent, String> {
    indent_graded(per_contact, None, backend, dt)
}

/// [`indent`] with the block graded: `per_contact` spacings per contact radius at
/// its base, `refined` (`Some`) within three contact radii of the point the sphere
/// first touches, the sphere sampled at the fine spacing.
pub fn indent_graded(
    per_contact: f64,
    refined: Option<f64>,
    backend: &str,
    dt: Option<f32>,
) -> Result<Indent, String> {
    let spacing = (indent_contact_radius() / per_contact) as f32;
    let fine = refined.map_or(spacing, |n| (indent_contact_radius() / n) as f32);
    let (width, depth) = (0.14f32, 0.08f32);
    let refine = match refined {
        Some(_) => format!(
            "refine = [{{ centre = [0.0, {}, 0.0], radius = {}, spacing = {fine} }}]",
            0.5 * depth,
            3.0 * indent_contact_radius()
        ),
        None => String::new(),
    };
    let r = INDENT_RADIUS as f32;
    let gap = 1e-4f32;
    let y_sphere = 0.5 * depth + gap + r;
    let hold = -0.5 * depth + 0.5 * spacing;
    let text = format!(
        r#"name = "indent"
gravity = [0.0, 0.0, 0.0]

[[objects]]
name = "block"
shape = {{ type = "box", size = [{width}, {depth}, {width}] }}
spacing = {spacing}
{refine}
influence = 3
material = {{ young = 1.0e5, poisson = 0.3 }}
fixed = [{{ min = [-1.0, -1.0, -1.0], max = [1.0, {hold}, 1.0] }}]

[[objects]]
name = "sphere"
backend = "kinematic"
shape = {{ type = "sphere", radius = {r} }}
spacing = {fine}
position = [0.0, {y_sphere}, 0.0]
velocity = [0.0, -0.01, 0.0]
material = {{ young = 1.0e9, poisson = 0.3 }}
"#
    );
    let mut w = build_text(&text, "indent", backend, dt)?;
    let material = w.objects[0].material.clone();
    let top = 0.5 * depth as f64;
    let depth_of = |w: &World| top - (com(w, 1).y - INDENT_RADIUS);
    let steps = ((INDENT_DEPTH + gap as f64) / 0.01 / w.dt as f64).ceil() as usize;
    let info = timed(&mut w, steps, |w| depth_of(w) < INDENT_DEPTH);
    let delta = depth_of(&w);
    let force = w.objects[1]
        .dynamics_as::<Kinematic>()
        .map_or(0.0, |k| k.reaction().y as f64);
    let radius = w.contact.patches.first().map_or(0.0, |patch| {
        let pts: Vec<ContactPoint> = patch.surfels.iter().map(ContactPoint::of).collect();
        let f_n = |p: &ContactPoint| Vec3::from(p.penalty_force).length() as f64;
        let total: f64 = pts.iter().map(f_n).sum();
        let r2 = |p: &ContactPoint| {
            let x = Vec3::from(p.position).as_dvec3();
            x.x * x.x + x.z * x.z
        };
        let second = pts.iter().map(|p| f_n(p) * r2(p)).sum::<f64>() / total.max(1e-300);
        // Hertz's pressure `p₀ √(1 − r²/a²)` has second moment ⅖ a².
        (2.5 * second).sqrt()
    });
    let (e, nu) = (material.young as f64, material.poisson as f64);
    let e_star = e / (1.0 - nu * nu);
    Ok(Indent {
        force,
        hertz: 4.0 / 3.0 * e_star * INDENT_RADIUS.sqrt() * delta.powf(1.5),
        radius,
        hertz_radius: (INDENT_RADIUS * delta).sqrt(),
        run: info,
    })
}

/// Block spacings of the indentation rows, as contact radii per spacing.
fn per_contact(quick: bool) -> &'static [f64] {
    if quick {
        &[1.5, 2.0, 2.5]
    } else {
        &[2.0, 3.0, 4.0]
    }
}

/// Indentation rows: the rigid sphere's force at a tenth of its radius deep against
/// Hertz's, at three block spacings ([`indent`]), within [`indent_tolerance`].
pub fn case_indent(backend: &str, quick: bool) -> Result<Vec<Row>, String> {
    sweep_by(
        "indent",
        backend,
        indent_tolerance,
        per_contact(quick),
        |n| {
            let s = indent(n, backend, None)?;
            Ok(Point {
                measured: s.force,
                reference: s.hertz,
                run: s.run,
                note: format!(
                    "spacing = contact radius / {n}; patch radius {:.2} mm (Hertz {:.2} mm, {:+.1}%)",
                    1e3 * s.radius,
                    1e3 * s.hertz_radius,
                    100.0 * (s.radius / s.hertz_radius - 1.0)
                ),
                rel_error: None,
            })
        },
    )
}

/// Tolerance of `indent` at `per_contact` block spacings per contact radius (relative
/// error of the force): about 1.25 times the error measured on `mls` (+21% at 1.5,
/// +11–12% at 2 and 2.5, +3.8% at 3, +1.2% at 4), and at 3 and finer the issue's aim,
/// 10%. The force is high at coarse spacings by the penalty layer and the held bottom.
pub fn indent_tolerance(per_contact: f64) -> f64 {
    if per_contact <= 1.5 {
        0.27
    } else if per_contact <= 2.5 {
        0.15
    } else {
        0.10
    }
}
