//! `phyxel compare`: one scene once per backend, side by side.

use phyxel::app::summary::{RunOptions, RunSummary, run};
use phyxel::backends;
use phyxel::scene::{BuildOptions, Preset, Scene};
use phyxel::world::phase::Phase;
use std::process::ExitCode;

use super::run::{note_run, resolve_scene, step_bar};

/// `phyxel compare`: the scene once per backend and preset, like `run --backend B
/// --preset P`. Runs `arg` once per backend of `names` and preset of `presets`;
/// `(dt, allow_unstable)` are `--dt` and `--allow-unstable`, as for `run`.
pub(crate) fn compare(
    arg: &str,
    names: &[String],
    presets: &[Preset],
    steps: Option<u64>,
    json: bool,
    (dt, allow_unstable): (Option<f32>, bool),
) -> ExitCode {
    // "mls, sph" is meant as "mls,sph".
    let names: Vec<String> = names.iter().map(|b| b.trim().to_string()).collect();
    for (k, b) in names.iter().enumerate() {
        if !backends::NAMES.contains(&b.as_str()) {
            eprintln!(
                "error: --backends: unknown backend '{b}' (available: {})",
                backends::NAMES.join(", ")
            );
            return ExitCode::FAILURE;
        }
        if names[..k].contains(b) {
            eprintln!("error: --backends: '{b}' is listed twice");
            return ExitCode::FAILURE;
        }
    }
    let names = &names[..];
    if names.is_empty() {
        eprintln!("error: --backends: give at least one backend");
        return ExitCode::FAILURE;
    }
    let Some((scene, file_prefix)) = resolve_scene(arg) else {
        return ExitCode::FAILURE;
    };
    // Backends move only the moving objects: with none, every row would be the same.
    if scene.objects.iter().all(|o| o.is_static) {
        eprintln!(
            "error: {file_prefix}every object is static (`static = true`): the backends have \
             nothing to move, so there is nothing to compare; run it with `phyxel run`"
        );
        return ExitCode::FAILURE;
    }
    let total = steps.unwrap_or(scene.steps);
    let runs: Vec<(&String, Preset)> = names
        .iter()
        .flat_map(|b| presets.iter().map(move |&p| (b, p)))
        .collect();
    // Every run's build checked before any runs: a refused one (a dt above one
    // backend's stable bound) would otherwise discard the runs made before it.
    let options = |b: &String, preset: Preset| RunOptions {
        build: BuildOptions {
            backend: Some(b.clone()),
            dt,
            allow_unstable,
            preset: Some(preset),
            ..Default::default()
        },
        steps,
        ..Default::default()
    };
    for &(b, preset) in &runs {
        if let Err(e) = scene.build(&options(b, preset).build) {
            eprintln!("error: backend {b}: {file_prefix}{e} (nothing was run)");
            return ExitCode::FAILURE;
        }
    }
    let mut summaries = Vec::with_capacity(runs.len());
    for (k, &(b, preset)) in runs.iter().enumerate() {
        let with = if preset == Preset::Default {
            String::new()
        } else {
            format!(", preset {}", preset.name())
        };
        eprintln!(
            "[{}/{}] {} with backend {b}{with}: {total} steps",
            k + 1,
            runs.len(),
            scene.name
        );
        let opts = options(b, preset);
        let bar = step_bar(total, b);
        let result = run(&scene, &opts, |s| {
            if s % 16 == 0 {
                bar.set_position(s);
            }
        });
        bar.finish_and_clear();
        match result {
            Ok((_, summary)) => summaries.push(summary),
            Err(e) => {
                eprintln!("error: backend {b}: {file_prefix}{e}");
                return ExitCode::FAILURE;
            }
        }
    }
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&summaries).expect("summaries serialise")
        );
    } else {
        print_comparison(&scene, &summaries);
    }
    let blown: Vec<String> = summaries
        .iter()
        .filter(|s| !s.finite)
        .map(RunSummary::series)
        .collect();
    for s in &summaries {
        note_run(&format!("backend {}: ", s.series()), s);
    }
    for e in summaries.iter().filter_map(|s| s.non_finite.as_ref()) {
        eprintln!("error: {e}; that run stopped there");
    }
    if blown.is_empty() {
        ExitCode::SUCCESS
    } else {
        eprintln!(
            "error: the state became non-finite (NaN or infinity) with backend(s) {}",
            blown.join(", ")
        );
        ExitCode::FAILURE
    }
}

/// Total energy at the end of a run (J): kinetic plus the elastic energy the backends
/// report.
pub(crate) fn end_energy(s: &RunSummary) -> f64 {
    s.kinetic_energy
        + s.bodies
            .iter()
            .filter_map(|b| b.elastic_energy)
            .sum::<f64>()
}

/// Momentum drift `|p_end − p_start|` (kg·m/s).
pub(crate) fn momentum_drift(s: &RunSummary) -> f64 {
    (0..3)
        .map(|k| (s.momentum_final[k] - s.momentum_initial[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

pub(crate) fn print_comparison(scene: &Scene, runs: &[RunSummary]) {
    let Some(first) = runs.first() else {
        return;
    };
    println!(
        "scene {}  objects {}  phyxels {}  surfels {}  steps {}",
        first.scene, first.objects, first.phyxels, first.surfels, first.steps
    );
    // The label column fits the longest `backend/preset`.
    let w = runs
        .iter()
        .map(|s| s.series().len())
        .max()
        .unwrap_or(0)
        .max(8);
    println!(
        "{:<w$} {:>10} {:>9} {:>10} {:>14} {:>14} {:>12} {:>7} {:>9}",
        "backend",
        "dt (s)",
        "time (s)",
        "steps/s",
        "max pen. (m)",
        "|dp| (kg m/s)",
        "energy (J)",
        "finite",
        "error"
    );
    for s in runs {
        // The scene's error against its reference, where it has one (Hertz).
        let error = phyxel::app::validate::scene_error(scene, s)
            .map_or_else(|| "-".to_string(), |e| format!("{e:.3e}"));
        println!(
            "{:<w$} {:>10.3e} {:>9.4} {:>10.1} {:>14.3e} {:>14.3e} {:>12.4e} {:>7} {:>9}",
            s.series(),
            s.dt,
            // Each backend runs at its own stable dt: the same steps cover different times.
            s.dt as f64 * s.steps as f64,
            s.steps_per_second,
            s.max_penetration,
            momentum_drift(s),
            end_energy(s),
            s.finite,
            error
        );
    }
    print!("{:<16}", "ms/step");
    for s in runs {
        print!(" {:>w$}", s.series());
    }
    println!();
    for p in Phase::ALL {
        print!("{:<16}", p.name());
        for s in runs {
            let t = s.phase_seconds.get(p.name()).copied().unwrap_or(0.0);
            print!(" {:>w$.4}", 1e3 * t / s.steps.max(1) as f64);
        }
        println!();
    }
}
