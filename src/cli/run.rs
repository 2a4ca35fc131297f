//! `phyxel run`: one scene with a progress bar, its summary as a table or JSON, frames
//! and a flamegraph on request.

use indicatif::{ProgressBar, ProgressStyle};
use phyxel::app::summary::{RunOptions, RunSummary, run};
use phyxel::backends;
use phyxel::scene::Scene;
use phyxel::world::phase::Phase;
use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use super::profile::{start_profiler, write_flamegraph};

use phyxel::app::out_dir;
pub(crate) use phyxel::app::out_dir::make_dir;

/// A flag that the first Ctrl-C sets (the run then stops after the step in flight and
/// its frame; during the build, after the first step); a second Ctrl-C exits at once
/// with 130, the shell's code for SIGINT. Frames are written whole or not at all
/// ([`phyxel::io::atomic`]), so even that leaves no truncated frame, but it writes no
/// manifest and may leave a hidden temporary: the next run into the folder wants
/// `--overwrite`.
fn on_ctrl_c() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let set = flag.clone();
    // Only one handler per process: a second call (not made by the CLI) keeps the first.
    let _ = ctrlc::set_handler(move || {
        if set.swap(true, Ordering::Relaxed) {
            std::process::exit(130);
        }
        eprintln!("\nCtrl-C: stopping after this step (again to quit at once)");
    });
    flag
}

pub(crate) fn run_scene(
    arg: &str,
    opts: &RunOptions,
    json: bool,
    flamegraph: Option<&Path>,
) -> ExitCode {
    // Command-line overrides are checked here so the error names the option, not the scene.
    if let Some(b) = &opts.build.backend
        && !backends::NAMES.contains(&b.as_str())
    {
        eprintln!(
            "error: --backend {b}: unknown backend (available: {})",
            backends::NAMES.join(", ")
        );
        return ExitCode::FAILURE;
    }
    if let Some(dir) = &opts.out
        && let Err(e) = make_dir(dir)
    {
        eprintln!("error: --out {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    let Some((scene, file_prefix)) = resolve_scene(arg) else {
        return ExitCode::FAILURE;
    };
    if let Err(e) = check_side_outputs(arg, &scene, opts, flamegraph) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    let steps = opts.steps.unwrap_or(scene.steps);
    let opts = &RunOptions {
        interrupt: Some(on_ctrl_c()),
        ..opts.clone()
    };
    let bar = step_bar(steps, &scene.name);
    let profiler = match flamegraph.map(start_profiler).transpose() {
        Ok(p) => p,
        Err(e) => {
            let path = flamegraph.expect("a profiler only for --flamegraph");
            eprintln!("error: --flamegraph {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    };
    // On a terminal, a run estimated past a minute says so once, about a second in
    // (timed from the first step's end: the build and the first frame are not steps).
    let (mut start, mut told) = (None, bar.is_hidden());
    let result = run(&scene, opts, |s| {
        let (t0, s0) = *start.get_or_insert((std::time::Instant::now(), s));
        if s % 16 == 0 {
            bar.set_position(s);
        }
        let elapsed = t0.elapsed().as_secs_f64();
        if !told && elapsed > 1.0 && s > s0 {
            told = true;
            let total = elapsed / (s - s0) as f64 * (steps - s0) as f64;
            if total > 60.0 {
                bar.println(format!(
                    "{steps} steps: about {} of wall time at this rate (Ctrl-C stops \
                     after the step in flight, with the summary)",
                    duration_words(total)
                ));
            }
        }
    });
    bar.finish_and_clear();
    // A flamegraph that cannot be written fails the command, after the run's summary:
    // the run itself is a result.
    let mut profile_failed = false;
    if let (Some((guard, file)), Some(path)) = (profiler, flamegraph) {
        match write_flamegraph(&guard, file) {
            Ok(Some(own)) => {
                eprintln!(
                    "flamegraph {}: {} samples; top frames by own time:",
                    path.display(),
                    own.samples
                );
                for (frame, percent) in &own.top {
                    eprintln!("  {percent:5.1}%  {frame}");
                }
            }
            Ok(None) => {
                // The temporary made up front is removed with its AtomicFile: a file
                // that was there stays as it was.
                eprintln!(
                    "warning: --flamegraph {}: no samples (the run was shorter than the \
                     profiler's 1 ms period); no file written: run more --steps",
                    path.display()
                );
            }
            Err(e) => {
                eprintln!("error: --flamegraph {}: {e}", path.display());
                profile_failed = true;
            }
        }
    }
    let (world, summary) = match result {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {file_prefix}{e}");
            return ExitCode::FAILURE;
        }
    };
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&summary).expect("summary serialises")
        );
    } else {
        print_table(&summary);
    }
    note_run("", &summary);
    if profile_failed {
        ExitCode::FAILURE
    } else if summary.interrupted {
        eprintln!(
            "interrupted after step {} of {steps}; the summary and frames cover those steps",
            summary.steps
        );
        ExitCode::from(130)
    } else if summary.finite {
        ExitCode::SUCCESS
    } else {
        match &summary.non_finite {
            // A blow-up in the very first step is rarely the time step: a scene whose
            // sizes and material leave f32's range fails at once, at any dt.
            Some(e) if world.non_finite.as_ref().is_some_and(|n| n.step <= 1) => eprintln!(
                "error: {e}; the run stopped there, in its first step: check the scene's \
                 sizes and material for values far outside everyday ones (f32 range), or \
                 try a smaller --dt"
            ),
            Some(e) => eprintln!("error: {e}; the run stopped there (try a smaller --dt)"),
            None => eprintln!(
                "error: the state became non-finite (NaN or infinity); try a smaller --dt"
            ),
        }
        ExitCode::FAILURE
    }
}

/// Warns on stderr of the build's `warnings` and of an energy gain (`energy_warning`),
/// and tells that the run lowered its dt (`dt_changes`): the first change, and how many
/// there were in all.
pub(crate) fn note_run(prefix: &str, s: &RunSummary) {
    if let Some(hint) = &s.backend_hint {
        eprintln!("note: {prefix}{hint}");
    }
    for w in &s.warnings {
        eprintln!("warning: {prefix}{w}");
    }
    if let Some(w) = &s.energy_warning {
        eprintln!("warning: {prefix}{w}");
    }
    // Steps accepted at the f32 floor are converged as far as f32 forces allow, but not
    // to the tolerance: said, so that a residual above it is never silent.
    for b in &s.bodies {
        if let Some(v) = b.solver.filter(|v| v.at_floor > 0) {
            eprintln!(
                "note: {prefix}object '{}': {} of {} implicit steps were accepted at the f32 \
                 floor of the forces, above the tolerance {:e} (largest relative residual of \
                 any step {:.3e})",
                b.name, v.at_floor, v.steps, v.tolerance, v.max_residual
            );
        }
    }
    let Some(first) = s.dt_changes.first() else {
        return;
    };
    eprintln!("note: {prefix}{first}");
    if s.dt_changes.len() > 1 {
        eprintln!(
            "note: {prefix}dt was lowered {} times in all, to {:.3e} s",
            s.dt_changes.len(),
            s.dt
        );
    }
    eprintln!(
        "note: {prefix}the {} steps cover {:.4e} s of simulated time",
        s.steps, s.time
    );
}

pub(crate) fn print_table(s: &RunSummary) {
    println!(
        "scene {}  backend {}  objects {}  phyxels {}  surfels {}",
        s.scene, s.backend, s.objects, s.phyxels, s.surfels
    );
    let bound = if s.stable_dt.is_finite() {
        format!("stable bound {:.3e} s", s.stable_dt)
    } else {
        "no stable bound: no object has elastic forces".to_string()
    };
    println!(
        "{} steps of dt {:.3e} s ({bound}) in {:.3} s: {:.1} steps/s",
        s.steps, s.dt, s.wall_seconds, s.steps_per_second
    );
    let total: f64 = s.phase_seconds.values().sum();
    println!(
        "{:<16} {:>10} {:>8} {:>12}",
        "phase", "seconds", "share", "ms/step"
    );
    for p in Phase::ALL {
        let t = s.phase_seconds[p.name()];
        println!(
            "{:<16} {:>10.4} {:>7.1}% {:>12.4}",
            p.name(),
            t,
            if total > 0.0 { 100.0 * t / total } else { 0.0 },
            1e3 * t / s.steps.max(1) as f64
        );
    }
    println!(
        "momentum {:?} -> {:?}  finite {}  max penetration {:.3e} m",
        s.momentum_initial, s.momentum_final, s.finite, s.max_penetration
    );
    for b in &s.bodies {
        println!(
            "  body {} '{}' ({}) mass {:.4} kg  com [{:.4}, {:.4}, {:.4}]  v [{:.4}, {:.4}, {:.4}]",
            b.id,
            b.name,
            b.backend,
            b.mass,
            b.com[0],
            b.com[1],
            b.com[2],
            b.velocity[0],
            b.velocity[1],
            b.velocity[2]
        );
    }
}

/// Refuses `--contacts` and `--flamegraph` paths that would overwrite an input, each
/// other, or the frames' folder and its files ([`out_dir::check_side_output`]).
fn check_side_outputs(
    arg: &str,
    scene: &Scene,
    opts: &RunOptions,
    flamegraph: Option<&Path>,
) -> Result<(), String> {
    let mut inputs: Vec<std::path::PathBuf> = Vec::new();
    if Scene::builtin(arg).is_none() {
        let file = Path::new(arg);
        let base = file.parent().unwrap_or(Path::new(""));
        inputs.push(file.to_path_buf());
        for o in &scene.objects {
            if let phyxel::body::shape::Shape::Mesh { path, .. } = &o.shape {
                inputs.push(base.join(path));
            }
        }
    }
    let inputs: Vec<&Path> = inputs.iter().map(|p| p.as_path()).collect();
    let outputs = [
        ("--contacts", opts.contacts.as_deref()),
        ("--flamegraph", flamegraph),
    ];
    for (k, (flag, path)) in outputs.iter().enumerate() {
        let Some(path) = path else { continue };
        let others: Vec<&Path> = outputs[..k].iter().filter_map(|o| o.1).collect();
        out_dir::check_side_output(path, opts.out.as_deref(), &inputs, &others)
            .map_err(|e| format!("{flag} {}: {e}", path.display()))?;
    }
    Ok(())
}

/// The scene `arg` names (built-in or file) and the prefix for errors from building it:
/// errors from a scene file name the scene, so the file is prefixed to name it too.
/// `None` after printing the error.
pub(crate) fn resolve_scene(arg: &str) -> Option<(Scene, String)> {
    let file_prefix = if Scene::builtin(arg).is_some() {
        String::new()
    } else {
        format!("{arg}: ")
    };
    match Scene::resolve(arg) {
        Ok(s) => Some((s, file_prefix)),
        Err(e) => {
            eprintln!("error: {e}");
            None
        }
    }
}

/// A progress bar over `steps` steps labelled `label`, on stderr when it is a terminal
/// (hidden otherwise, so that piped output stays clean).
pub(crate) fn step_bar(steps: u64, label: &str) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(steps);
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} steps ({per_sec}, eta {eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message(label.to_string());
    bar
}

/// `seconds` in the largest unit that keeps it readable: "45 s", "12 min", "3.2 h",
/// "41 days", "3.1e5 years".
fn duration_words(seconds: f64) -> String {
    let (m, h, d, y) = (60.0, 3600.0, 86_400.0, 365.25 * 86_400.0);
    match seconds {
        s if s < m => format!("{s:.0} s"),
        s if s < h => format!("{:.0} min", s / m),
        s if s < d => format!("{:.1} h", s / h),
        s if s < y => format!("{:.0} days", s / d),
        s if s < 1e4 * y => format!("{:.0} years", s / y),
        s => format!("{:.1e} years", s / y),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn durations_read_in_their_unit() {
        let cases = [
            (45.0, "45 s"),
            (720.0, "12 min"),
            (11_520.0, "3.2 h"),
            (3_542_400.0, "41 days"),
            (9.78e12, "3.1e5 years"),
        ];
        for (s, words) in cases {
            assert_eq!(super::duration_words(s), words);
        }
    }
}
