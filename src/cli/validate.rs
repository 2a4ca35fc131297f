//! `phyxel validate`: the validation suite with progress, its table, charts and JSON.

use crate::cli::run::make_dir;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;

/// `phyxel validate`: runs the suite, prints the table (or JSON), writes the charts;
/// fails when a row fails.
pub(crate) fn validate(
    quick: bool,
    backend: Option<String>,
    json: bool,
    plot: Option<&Path>,
    only: Option<&str>,
    presets: &[phyxel::scene::Preset],
) -> ExitCode {
    use phyxel::app::validate;
    if let Some(b) = &backend
        && let Err(e) = validate::check_backend(b)
    {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    if let Some(c) = only
        && let Err(e) = validate::check_case(c)
    {
        eprintln!("error: --{e}");
        return ExitCode::FAILURE;
    }
    if let Some(dir) = plot
        && let Err(e) = make_dir(dir)
    {
        eprintln!("error: --plot {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    let bar = if std::io::stderr().is_terminal() {
        let b = ProgressBar::new_spinner();
        b.set_style(
            ProgressStyle::with_template("{spinner} [{elapsed}] {msg}").expect("valid template"),
        );
        b.enable_steady_tick(std::time::Duration::from_millis(200));
        b
    } else {
        ProgressBar::hidden()
    };
    let t0 = std::time::Instant::now();
    let report = |label: &str| {
        bar.set_message(label.to_string());
        if !std::io::stderr().is_terminal() {
            eprintln!("[{:6.1} s] {label}", t0.elapsed().as_secs_f64());
        }
    };
    let backends: Vec<String> = backend.into_iter().collect();
    let mut rows = Vec::new();
    for &p in presets {
        validate::with_preset(p, || {
            rows.extend(validate::run_accuracy(&backends, quick, only, report));
            rows.extend(validate::run_stability(&backends, quick, only, report));
        });
    }
    bar.finish_and_clear();
    if rows.is_empty() {
        let names: Vec<&str> = validate::CASES
            .iter()
            .map(|c| c.0)
            .chain(validate::STABILITY_CASES.iter().copied())
            .collect();
        // A case that exists but not for the chosen backend: say so.
        let for_backend = match (only, &backends[..]) {
            (Some(c), [b]) if names.iter().any(|n| n.starts_with(c)) => {
                format!(" that applies to backend {b} (see docs/ACCURACY.md, \"Per backend\")")
            }
            _ => String::new(),
        };
        eprintln!(
            "error: --case {}: no case matches{for_backend} (cases: {}, or `stability`)",
            only.unwrap_or(""),
            names.join(", ")
        );
        return ExitCode::FAILURE;
    }
    eprintln!("validation took {:.1} s", t0.elapsed().as_secs_f64());
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&rows).expect("rows serialise")
        );
    } else {
        print!("{}", validate::table(&rows));
        for (case, b, first, last) in validate::convergence(&rows) {
            println!(
                "{case} ({b}): error {first:.3e} at the coarsest, {last:.3e} at the finest resolution{}",
                if last < first { "" } else { "  (NOT falling)" }
            );
        }
    }
    if let Some(dir) = plot {
        match validate::plot(&rows, dir) {
            Ok(notes) => {
                for n in notes {
                    eprintln!("{n}");
                }
            }
            Err(e) => {
                eprintln!("error: --plot {}: {e}", dir.display());
                return ExitCode::FAILURE;
            }
        }
    }
    let failed = rows.iter().filter(|r| !r.pass).count();
    if failed == 0 {
        ExitCode::SUCCESS
    } else {
        eprintln!("error: {failed} of {} rows failed", rows.len());
        ExitCode::FAILURE
    }
}
