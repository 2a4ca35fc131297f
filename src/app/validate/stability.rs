//! The hard cases (`stability` group): each run and judged stable (finite, penetration
//! bounded, its own check) or refused up front.

use super::*;

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
        preset: preset_name(),
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

/// A hard case's runner: (backend, its build options, quick) → its row.
pub type HardCaseFn = fn(&str, &BuildOptions, bool) -> Row;

/// The hard cases, in the order of [`STABILITY_CASES`], each with its runner.
///
/// - `stiff-material`: a sphere of E = 1e9 Pa (1e4 × the default) hitting a plane of
///   the same stiffness at 1 m/s, at the default (stable) dt, bouncing within 4 ms (or
///   three steps);
/// - `dt-at-bound`: `sphere-on-plane` at exactly the stable bound;
/// - `dt-above-bound`: the same at 2× the bound: must be refused up front (the message
///   names the bound and the remedy); a backend without a bound runs both at a frame-rate
///   step ([`UNBOUNDED_CASE_DT`], twice it above) and must stay stable;
/// - `high-speed-impact`: two spheres closing at 12 m/s, each surfel moving more than a
///   surfel spacing per step: must not tunnel (they end up apart in their original order);
/// - `deep-penetration`: `soft-on-plane` (the paper's Fig. 3 soft sphere);
/// - `one-phyxel-plate`: a plate one phyxel thick (rank-2 moment matrices) dropped on a plane.
///
/// Penetration bounds: the sphere radius for deep penetration, 10% of it elsewhere, the
/// plate thickness for the plate.
pub const HARD_CASES: &[(&str, HardCaseFn)] = &[
    ("stiff-material", stiff_material),
    ("dt-at-bound", dt_at_bound),
    ("dt-above-bound", dt_above_bound),
    ("high-speed-impact", high_speed_impact),
    ("deep-penetration", deep_penetration),
    ("one-phyxel-plate", one_phyxel_plate),
];

/// The hard cases for `backend` whose name starts with `only` (all when `None` or a
/// prefix of "stability"); `quick` shortens the runs.
pub fn stability(
    backend: &str,
    quick: bool,
    only: Option<&str>,
    mut progress: impl FnMut(&str),
) -> Vec<Row> {
    let o = opts(backend);
    let want = |c: &str| only.is_none_or(|o| c.starts_with(o) || "stability".starts_with(o));
    HARD_CASES
        .iter()
        .filter(|(case, _)| want(case))
        .map(|(case, run)| {
            progress(&format!("{case} ({backend})"));
            run(backend, &o, quick)
        })
        .collect()
}

/// Very stiff material: a sphere of E = 1e9 Pa hits a plane of the same stiffness at
/// 1 m/s and must bounce within 4 ms (or three steps, if longer).
fn stiff_material(backend: &str, o: &BuildOptions, _quick: bool) -> Row {
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
    match build(&s, o) {
        Ok(w) => {
            // Three steps at least (the implicit backend's default dt is 8 ms).
            let time = 0.004f32.max(3.5 * w.dt);
            run_hard("stiff-material", backend, w, time, 0.01, move |w| {
                let v = w.objects[1].phyxels.momentum()[1];
                if v > 0.0 {
                    Ok(())
                } else {
                    Err(format!("did not bounce within {:.1} ms", 1e3 * time))
                }
            })
        }
        Err(e) => hard_error("stiff-material", backend, e),
    }
}

/// `sphere-on-plane` and its stable bound (s).
fn at_bound_scene(o: &BuildOptions) -> Result<(Scene, f32), String> {
    let s = builtin("sphere-on-plane");
    let bound = build(&s, o)?.stable_dt().0;
    Ok((s, bound))
}

/// The step an unbounded (implicit) backend runs the bound cases at instead: a
/// frame-rate step at the bound, twice it above.
pub const UNBOUNDED_CASE_DT: f32 = 1.0 / 120.0;

/// `sphere-on-plane` at exactly the stable bound (a backend without one, and whose
/// contacts join its solve: at [`UNBOUNDED_CASE_DT`]).
fn dt_at_bound(backend: &str, o: &BuildOptions, quick: bool) -> Row {
    let scale = if quick { 0.5 } else { 1.0 };
    let at = |(s, bound): (Scene, f32)| {
        let at = BuildOptions {
            dt: Some(if bound.is_finite() {
                bound
            } else {
                UNBOUNDED_CASE_DT
            }),
            ..o.clone()
        };
        build(&s, &at)
    };
    match at_bound_scene(o).and_then(at) {
        Ok(w) => run_hard("dt-at-bound", backend, w, 0.3 * scale, 0.01, |_| Ok(())),
        Err(e) => hard_error("dt-at-bound", backend, e),
    }
}

/// `sphere-on-plane` at twice the stable bound: must be refused up front, naming the
/// bound; forced with `allow_unstable`, the run shows the refusal was needed.
fn dt_above_bound(backend: &str, o: &BuildOptions, _quick: bool) -> Row {
    let (s, bound) = match at_bound_scene(o) {
        Ok(sb) => sb,
        Err(e) => return hard_error("dt-above-bound", backend, e),
    };
    if bound == f32::INFINITY {
        // No bound to exceed: twice the frame-rate step must still run stable.
        let at = BuildOptions {
            dt: Some(2.0 * UNBOUNDED_CASE_DT),
            ..o.clone()
        };
        return match build(&s, &at) {
            Ok(w) => run_hard("dt-above-bound", backend, w, 0.5, 0.01, |_| Ok(())),
            Err(e) => hard_error("dt-above-bound", backend, e),
        };
    }
    let above = BuildOptions {
        dt: Some(2.0 * bound),
        ..o.clone()
    };
    match build(&s, &above) {
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
            let forced = BuildOptions {
                allow_unstable: true,
                ..above
            };
            if let Ok(mut w) = build(&s, &forced) {
                let mut n = 0;
                timed(&mut w, 2000, |w| {
                    n += 1;
                    w.non_finite.is_none() && w.all_finite()
                });
                // (A blow-up may first leave f32's range: `NonFinite::out_of_range`.)
                r.note += &if let Some(e) = &w.non_finite {
                    format!(" [forced with --allow-unstable: blew up: {e}]")
                } else if !w.all_finite() {
                    format!(" [forced with --allow-unstable: non-finite after {n} steps]")
                } else {
                    " [forced with --allow-unstable: still finite after 2000 steps]".into()
                };
            }
            r
        }
        Err(e) => hard_error(
            "dt-above-bound",
            backend,
            format!("refused without naming the bound: {e}"),
        ),
        Ok(_) => hard_error(
            "dt-above-bound",
            backend,
            "dt = 2× the stable bound was accepted".into(),
        ),
    }
}

/// Two spheres closing at 12 m/s, each surfel moving more than a surfel spacing per
/// step: they must not tunnel.
fn high_speed_impact(backend: &str, o: &BuildOptions, quick: bool) -> Row {
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
    match build(&s, o) {
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
    }
}

/// Deep penetration: the soft sphere of `soft-on-plane` (the paper's Fig. 3) must not
/// fall through.
fn deep_penetration(backend: &str, o: &BuildOptions, quick: bool) -> Row {
    let scale = if quick { 0.5 } else { 1.0 };
    let mut s = builtin("soft-on-plane");
    if quick {
        // Coarser surfels (1 cm instead of 5 mm): the plane's surfels set the cost.
        for obj in s.objects.iter_mut() {
            obj.surfel_spacing = Some(0.01);
        }
    }
    match build(&s, o) {
        Ok(w) => run_hard("deep-penetration", backend, w, 1.0 * scale, 0.1, |w| {
            let y = com(w, 1).y;
            if y > 0.0 {
                Ok(())
            } else {
                Err(format!("fell through: centre at y = {y:.3} m"))
            }
        }),
        Err(e) => hard_error("deep-penetration", backend, e),
    }
}

/// Degenerate sampling: a plate one phyxel thick dropped on a plane.
fn one_phyxel_plate(backend: &str, o: &BuildOptions, quick: bool) -> Row {
    let scale = if quick { 0.5 } else { 1.0 };
    let mut s = builtin("sphere-on-plane");
    s.objects[1].shape = Shape::Box {
        size: [0.3, 0.025, 0.3],
    };
    s.objects[1].spacing = 0.025;
    s.objects[1].rotation = [0.0; 3];
    s.objects[1].position = [0.0, 0.03, 0.0];
    match build(&s, o) {
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
    }
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
