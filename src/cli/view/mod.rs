//! `phyxel view`: the simulation live in a window, with the paper's user-guided tool.
//!
//! The simulation steps in its own thread ([`sim`]) and publishes snapshots; the window
//! ([`window`]) draws the latest one with the software splat renderer and never waits
//! for a step. The mouse orbits, pans and zooms, drives the tool sphere (a kinematic
//! body, `phyxel::dynamics::kinematic`) and grabs bodies with a spring; keys pause,
//! step, reset, switch the backend, toggle gravity and set the speed. `--input` replays
//! scripted input ([`script`]), `--frames DIR` plays written frames ([`replay`]), and
//! `--screenshot FILE --after N` saves the window after N steps and exits (tests under
//! Xvfb).

mod bodies;
mod replay;
pub(crate) mod script;
mod sim;
mod window;

use phyxel::scene::{BuildOptions, Scene};
use sim::{Shared, Snapshot};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use window::{Source, Viewer, WindowOptions};

/// What `phyxel view` was asked for.
pub(crate) struct ViewOptions {
    pub build: BuildOptions,
    pub size: (u32, u32),
    pub screenshot: Option<PathBuf>,
    pub after: u64,
    /// Close after this many wall seconds and print the run's figures (measurements).
    pub seconds: Option<f64>,
    /// Simulated seconds per wall second at most (0: flat out).
    pub speed: f64,
    /// Scripted input (events.toml).
    pub input: Option<PathBuf>,
    /// Replay the frames in this folder instead of simulating.
    pub frames: Option<PathBuf>,
    /// Print the state shown as one JSON line when the window closes.
    pub json: bool,
    /// The scene's file, watched for changes (`None` for a built-in scene).
    pub file: Option<PathBuf>,
    /// Image pixels per window pixel (`None`: automatic).
    pub render_scale: Option<f32>,
    /// Threads of the simulation.
    pub threads: usize,
}

/// Runs `phyxel view` on `scene` (ignored with `--frames`).
pub(crate) fn view(scene: Option<Scene>, opts: ViewOptions) -> ExitCode {
    let exit: window::Exit = Arc::new(Mutex::new(None));
    let window_opts = WindowOptions {
        screenshot: opts.screenshot.clone(),
        after: opts.after,
        seconds: opts.seconds,
        report: opts.json,
        render_scale: opts.render_scale,
    };
    let (source, sim, shared, title) = match (&opts.frames, scene) {
        (Some(dir), _) => match replay::Replay::open(dir) {
            // `--after N` picks frame N of a replay: one past the end is no frame.
            Ok(r) if opts.screenshot.is_some() && opts.after >= r.len() => {
                eprintln!(
                    "error: --after {}: {} holds {} surfel frames (0..={}): give one of them",
                    opts.after,
                    dir.display(),
                    r.len(),
                    r.len() - 1
                );
                return ExitCode::FAILURE;
            }
            Ok(r) => (
                Source::Replay(r),
                None,
                None,
                format!("phyxel view: {}", dir.display()),
            ),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        },
        (None, Some(scene)) => {
            let script = match &opts.input {
                Some(path) => match script::Script::load(path) {
                    Ok(s) => s,
                    Err(e) => {
                        eprintln!("error: --input {e}");
                        return ExitCode::FAILURE;
                    }
                },
                None => script::Script::default(),
            };
            let shared = Arc::new(Shared {
                snapshot: Mutex::new(Snapshot::default()),
                quit: AtomicBool::new(false),
                stop_at: if opts.screenshot.is_some() {
                    opts.after
                } else {
                    u64::MAX
                },
            });
            let (send, receive) = std::sync::mpsc::channel();
            let thread = {
                let (shared, scene, build) = (shared.clone(), scene.clone(), opts.build.clone());
                let (speed, threads) = (opts.speed, opts.threads);
                std::thread::spawn(move || {
                    sim::simulate(scene, build, speed, script, receive, shared, threads)
                })
            };
            let file = opts.file.clone().map(|p| {
                let seen = std::fs::metadata(&p).and_then(|m| m.modified()).ok();
                (p, seen)
            });
            let source = Source::Live {
                shared: shared.clone(),
                commands: send,
                file,
            };
            (
                source,
                Some(thread),
                Some(shared),
                format!("phyxel view: {}", scene.name),
            )
        }
        (None, None) => unreachable!("a scene or --frames"),
    };
    let viewer = Viewer::new(source, window_opts, opts.speed, exit.clone());
    let (w, h) = opts.size;
    let native = eframe::NativeOptions {
        viewport: eframe::egui::ViewportBuilder::default()
            .with_inner_size([w as f32, h as f32])
            .with_title(title),
        ..Default::default()
    };
    let ran = eframe::run_native("phyxel", native, Box::new(|_cc| Ok(Box::new(viewer))));
    if let Some(shared) = shared {
        shared.quit.store(true, Ordering::Relaxed);
    }
    if let Some(t) = sim
        && t.join().is_err()
    {
        eprintln!("error: phyxel view: the simulation thread failed");
        return ExitCode::FAILURE;
    }
    if let Err(e) = ran {
        eprintln!("error: phyxel view: cannot open a window: {e} (no display? run under xvfb-run)");
        return ExitCode::FAILURE;
    }
    match exit.lock().expect("exit lock").take() {
        Some(Err(e)) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
        _ => ExitCode::SUCCESS,
    }
}
