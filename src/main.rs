//! The `phyxel` command line: run scenes, list them, show them as TOML.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use phyxel::app::render::{Camera, RenderOptions, camera_for, render};
use phyxel::app::summary::{RunOptions, RunSummary, run};
use phyxel::backends;
use phyxel::io::frame::Format;
use phyxel::io::import::read_frame;
use phyxel::scene::{BUILTIN, BuildOptions, DEFAULT_SCENE, Scene};
use phyxel::world::phase::Phase;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "phyxel",
    version,
    about = "Contact handling for deformable point-based objects"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Commands that take numbers allow negative ones, so that `--steps -1` or `--fov -10`
/// reach the value checks (naming the flag and its range) instead of reading as an
/// unknown flag `-1`.
#[derive(Subcommand)]
enum Command {
    /// Run a built-in scene or a scene file.
    #[command(allow_negative_numbers = true)]
    Run {
        /// Built-in scene name or path to a .toml scene file.
        #[arg(default_value = DEFAULT_SCENE)]
        scene: String,
        /// Number of steps (default: the scene's).
        #[arg(long)]
        steps: Option<u64>,
        /// Time step in seconds (default: the scene's, else 90% of the stable bound, at most 1 ms).
        #[arg(long, allow_hyphen_values = true)]
        dt: Option<f64>,
        /// Backend for every deformable object (overrides the scene).
        #[arg(long)]
        backend: Option<String>,
        /// Directory for PLY frames.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also write phyxel PLY frames to --out.
        #[arg(long)]
        phyxels: bool,
        /// File format of the surfel frames in --out: ply (binary PLY) or vtk (.vtp).
        #[arg(long, default_value = "ply", value_parser = ["ply", "vtk"])]
        format: String,
        /// Also render every frame to surfels_NNNNN.png in --out.
        #[arg(long, requires = "out")]
        png: bool,
        /// Image size for --png, WIDTHxHEIGHT [default: 800x600].
        #[arg(long, allow_hyphen_values = true)]
        size: Option<String>,
        /// Print the run summary as one JSON object on stdout.
        #[arg(long)]
        json: bool,
        /// Run even when dt exceeds the stable bound.
        #[arg(long)]
        allow_unstable: bool,
        /// Surfels per deformable object (overrides the scene's sampling; the `scale`
        /// scene is made for it).
        #[arg(long, value_name = "N")]
        surfels: Option<u32>,
        /// Phyxels per deformable object (overrides the scene's sampling).
        #[arg(long, value_name = "N")]
        phyxel_count: Option<u32>,
        /// Profile the run (sampling at 997 Hz of CPU time, or at the kernel's timer tick
        /// where that is coarser: 250 Hz on the CI machine) and write a flamegraph SVG; the
        /// phases appear as frames named like the timing table
        /// (`phyxel::world::step::detect`, ...), and the five frames of most own time are
        /// listed on stderr.
        #[arg(long, value_name = "FILE.svg")]
        flamegraph: Option<PathBuf>,
    },
    /// Run a scene once per backend and compare speed, contact and conservation.
    #[command(allow_negative_numbers = true)]
    Compare {
        /// Built-in scene name or path to a .toml scene file.
        #[arg(default_value = DEFAULT_SCENE)]
        scene: String,
        /// Comma-separated backends; each run uses it for every deformable object.
        #[arg(long, value_delimiter = ',', default_value = "mls,sph,lj")]
        backends: Vec<String>,
        /// Number of steps per run (default: the scene's).
        #[arg(long)]
        steps: Option<u64>,
        /// Print the run summaries as one JSON array on stdout (the `run --json` objects).
        #[arg(long)]
        json: bool,
        /// Time step (s) for every run (default: the scene's, else 90% of each backend's
        /// stable bound, at most 1 ms).
        #[arg(long, allow_hyphen_values = true)]
        dt: Option<f64>,
        /// Run even when dt exceeds a backend's stable bound.
        #[arg(long)]
        allow_unstable: bool,
    },
    /// Render a surfel frame (PLY) to a PNG image.
    #[command(allow_negative_numbers = true)]
    Render {
        /// A surfel PLY frame (from `run --out`) or any PLY point cloud with x y z.
        frame: PathBuf,
        /// Output PNG file.
        #[arg(short, long)]
        out: PathBuf,
        /// Image size, WIDTHxHEIGHT.
        #[arg(long, default_value = "800x600", allow_hyphen_values = true)]
        size: String,
        /// Take the camera from this scene's [camera] (built-in name or .toml file).
        #[arg(long)]
        scene: Option<String>,
        /// Camera position X,Y,Z (default: a 3/4 view fitted to the frame).
        #[arg(long, value_delimiter = ',', num_args = 1, allow_hyphen_values = true)]
        eye: Option<Vec<f32>>,
        /// Point the camera looks at, X,Y,Z (default: the frame's centre).
        #[arg(long, value_delimiter = ',', num_args = 1, allow_hyphen_values = true)]
        target: Option<Vec<f32>>,
        /// Vertical field of view in degrees [default: the scene camera's, else 35].
        #[arg(long)]
        fov: Option<f32>,
    },
    /// Run the validation suite: every case against its reference at several resolutions,
    /// with seconds per step against relative error, then the hard (stability) cases.
    #[command(allow_negative_numbers = true)]
    Validate {
        /// Coarse resolutions and short runs (under two minutes).
        #[arg(long)]
        quick: bool,
        /// Validate only this backend (default: every backend).
        #[arg(long)]
        backend: Option<String>,
        /// Print the rows as a JSON array on stdout.
        #[arg(long)]
        json: bool,
        /// Write speed-against-error charts (SVG and PNG, one per case) to this directory.
        #[arg(long, value_name = "DIR")]
        plot: Option<PathBuf>,
        /// Run only the cases whose name starts with this (e.g. `hertz`, `stability`).
        #[arg(long)]
        case: Option<String>,
    },
    /// List the built-in scenes, or print one as TOML.
    Scenes {
        /// Print this built-in scene as TOML (runnable with `phyxel run FILE.toml`).
        #[arg(long)]
        show: Option<String>,
        /// The same as `--show NAME`.
        #[arg(conflicts_with = "show")]
        name: Option<String>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Scenes { show, name } => scenes(show.or(name)),
        Command::Validate {
            quick,
            backend,
            json,
            plot,
            case,
        } => validate(quick, backend, json, plot.as_deref(), case.as_deref()),
        Command::Compare {
            scene,
            backends,
            steps,
            json,
            dt,
            allow_unstable,
        } => match dt.map(dt_option).transpose() {
            Ok(dt) => compare(&scene, &backends, steps, json, (dt, allow_unstable)),
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        },
        Command::Render {
            frame,
            out,
            size,
            scene,
            eye,
            target,
            fov,
        } => render_frame(&frame, &out, &size, scene.as_deref(), eye, target, fov),
        Command::Run {
            scene,
            steps,
            dt,
            backend,
            out,
            phyxels,
            format,
            png,
            size,
            json,
            allow_unstable,
            surfels,
            phyxel_count,
            flamegraph,
        } => {
            // Options that only shape output which is not being written: say so.
            let idle = [
                (phyxels && out.is_none(), "--phyxels", "--out"),
                (format != "ply" && out.is_none(), "--format", "--out"),
                (size.is_some() && !png, "--size", "--png"),
            ];
            for (_, flag, needs) in idle.iter().filter(|i| i.0) {
                eprintln!("warning: {flag} has no effect without {needs}");
            }
            // Read as f64 so that a value f32 cannot hold is reported as given.
            let dt = match dt.map(dt_option).transpose() {
                Ok(dt) => dt,
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::FAILURE;
                }
            };
            let size = size.unwrap_or_else(|| DEFAULT_SIZE.to_string());
            let (width, height) = match parse_size(&size) {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("error: --size {size}: {e}");
                    return ExitCode::FAILURE;
                }
            };
            let opts = RunOptions {
                format: Format::parse(&format).expect("clap checks the value"),
                png: png.then(|| RenderOptions {
                    width,
                    height,
                    ..Default::default()
                }),
                build: BuildOptions {
                    dt,
                    backend,
                    allow_unstable,
                    surfels,
                    phyxels: phyxel_count,
                },
                steps,
                out,
                phyxels,
            };
            run_scene(&scene, &opts, json, flamegraph.as_deref())
        }
    }
}

/// `--dt` as the engine's f32: finite, > 0 and within f32's normal range.
fn dt_option(dt: f64) -> Result<f32, String> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(format!("--dt {dt}: must be a finite number > 0"));
    }
    if !phyxel::scene::fits_f32(dt) {
        return Err(format!(
            "--dt {dt:e}: outside the range of f32 numbers ({:e} to {:e})",
            f32::MIN_POSITIVE,
            f32::MAX
        ));
    }
    Ok(dt as f32)
}

/// Image size of `run --png` when `--size` is not given.
const DEFAULT_SIZE: &str = "800x600";

/// Parses `WIDTHxHEIGHT`.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| "expected WIDTHxHEIGHT, e.g. 800x600".to_string())?;
    let parse = |v: &str| match v.trim().parse::<u32>() {
        Ok(n) if (16..=8192).contains(&n) => Ok(n),
        _ => Err(format!("'{v}': must be a whole number from 16 to 8192")),
    };
    Ok((parse(w)?, parse(h)?))
}

fn point(name: &str, v: Option<Vec<f32>>) -> Result<Option<[f32; 3]>, String> {
    match v {
        None => Ok(None),
        Some(v) if v.len() == 3 => Ok(Some([v[0], v[1], v[2]])),
        Some(v) => Err(format!("--{name}: expected X,Y,Z, got {} values", v.len())),
    }
}

fn render_frame(
    frame: &std::path::Path,
    out: &std::path::Path,
    size: &str,
    scene: Option<&str>,
    eye: Option<Vec<f32>>,
    target: Option<Vec<f32>>,
    fov: Option<f32>,
) -> ExitCode {
    let result = (|| -> Result<String, String> {
        let (width, height) = parse_size(size).map_err(|e| format!("--size {size}: {e}"))?;
        let surface = read_frame(frame)?;
        if surface.is_empty() {
            return Err(format!("{}: the frame has no points", frame.display()));
        }
        if out
            .extension()
            .is_none_or(|e| !e.eq_ignore_ascii_case("png"))
        {
            eprintln!("warning: -o {}: the image is written as PNG", out.display());
        }
        let mut opts = RenderOptions {
            width,
            height,
            ..Default::default()
        };
        if let Some(s) = scene {
            let scene = Scene::resolve(s).map_err(|e| e.to_string())?;
            if scene.camera.is_none() {
                eprintln!("warning: --scene {s}: the scene has no [camera]; fitting one");
            }
            opts.camera = scene.camera;
        }
        // The scene's camera (or one fitted to the frame), with any of its position,
        // target and field of view replaced by the options given.
        let (eye, target) = (point("eye", eye)?, point("target", target)?);
        let base = camera_for(&surface, &opts);
        let cam = Camera {
            position: eye.unwrap_or(base.position),
            target: target.unwrap_or(base.target),
            fov: fov.unwrap_or(base.fov),
            ..base
        };
        // Say where the camera came from: a fitted one is only as good as the frame's
        // bounds (a coordinate near f32's limit overflows the fit).
        let source = match (
            eye.is_some() || target.is_some() || fov.is_some(),
            scene,
            opts.camera,
        ) {
            (true, _, _) => "the options' camera".to_string(),
            (false, Some(s), Some(_)) => format!("the camera of scene {s}"),
            _ => format!("the camera fitted to {}'s bounds", frame.display()),
        };
        cam.validate().map_err(|e| format!("{source}: {e}"))?;
        opts.camera = Some(cam);
        render(&surface, &opts).write_png(out)?;
        Ok(format!(
            "{}: {} surfels -> {} ({width}x{height})",
            frame.display(),
            surface.len(),
            out.display()
        ))
    })();
    match result {
        Ok(msg) => {
            eprintln!("{msg}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn scenes(show: Option<String>) -> ExitCode {
    match show {
        None => {
            for (name, text) in BUILTIN {
                let scene = Scene::parse(text, name).expect("built-in scenes are valid");
                println!("{name:<16} {}", scene.description);
            }
            ExitCode::SUCCESS
        }
        Some(name) => match BUILTIN.iter().find(|(n, _)| *n == name) {
            Some((_, text)) => {
                print!("{text}");
                ExitCode::SUCCESS
            }
            None => {
                let names: Vec<&str> = BUILTIN.iter().map(|(n, _)| *n).collect();
                eprintln!(
                    "error: unknown scene '{name}' (built-in scenes: {})",
                    names.join(", ")
                );
                ExitCode::FAILURE
            }
        },
    }
}

/// Creates the output directory `dir` (and its parents). A path that exists as a file
/// is said to be one: `create_dir_all` reported "File exists", as if the trouble were
/// that something was there at all.
fn make_dir(dir: &Path) -> Result<(), String> {
    if dir.exists() && !dir.is_dir() {
        return Err("a file, not a directory: give a directory for the output".to_string());
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create the directory: {e}"))
}

/// A sampling profiler (timer signal, so no perf permissions are needed) and the file
/// its flamegraph goes to, created before the run so that a bad path fails at once,
/// not after the whole run.
fn start_profiler(path: &Path) -> Result<(pprof::ProfilerGuard<'static>, std::fs::File), String> {
    let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
    let guard = pprof::ProfilerGuardBuilder::default()
        .frequency(997)
        .blocklist(&["libc", "libgcc", "pthread", "vdso"])
        .build()
        .map_err(|e| format!("cannot start the profiler: {e}"))?;
    Ok((guard, file))
}

/// Frames listed after a flamegraph is written.
const TOP_FRAMES: usize = 5;

/// Writes the flamegraph and returns its samples with the [`TOP_FRAMES`] frames of most
/// own time; `Ok(None)` when the profiler took no sample (a run shorter than its 1 ms
/// period): there is no graph to draw, and an empty SVG is no picture.
fn write_flamegraph(
    guard: &pprof::ProfilerGuard<'_>,
    file: std::fs::File,
) -> Result<Option<OwnTime>, String> {
    let report = guard.report().build().map_err(|e| e.to_string())?;
    if report.data.is_empty() {
        return Ok(None);
    }
    report.flamegraph(file).map_err(|e| e.to_string())?;
    // The innermost symbol of a stack (inlined callees first) is the flamegraph's leaf.
    let leaves = report.data.iter().map(|(stack, &n)| {
        let leaf = stack.frames.first().and_then(|f| f.first());
        (
            leaf.map_or_else(|| "[unknown]".to_string(), |s| s.name()),
            n,
        )
    });
    Ok(Some(own_time(leaves, TOP_FRAMES)))
}

/// A profile's sample count and its frames of most own time, with their percentages.
struct OwnTime {
    samples: isize,
    top: Vec<(String, f64)>,
}

/// Sums the samples of `(leaf frame, samples)` stacks by frame (the symbol hash left
/// out, so that one function is one frame) and keeps the `k` largest, largest first
/// (equal counts by name). These are the widest tops of the flamegraph: where the time
/// is spent, as opposed to the phases that call it.
fn own_time(leaves: impl Iterator<Item = (String, isize)>, k: usize) -> OwnTime {
    let mut by_frame = std::collections::HashMap::<String, isize>::new();
    let mut samples = 0;
    for (name, n) in leaves {
        let name = match name.rsplit_once("::h") {
            Some((f, hash)) if hash.len() == 16 && hash.bytes().all(|b| b.is_ascii_hexdigit()) => {
                f.to_string()
            }
            _ => name,
        };
        *by_frame.entry(name).or_default() += n;
        samples += n;
    }
    let mut top: Vec<(String, isize)> = by_frame.into_iter().collect();
    top.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    top.truncate(k);
    let share = |n: isize| 100.0 * n as f64 / samples.max(1) as f64;
    OwnTime {
        samples,
        top: top.into_iter().map(|(f, n)| (f, share(n))).collect(),
    }
}

fn run_scene(arg: &str, opts: &RunOptions, json: bool, flamegraph: Option<&Path>) -> ExitCode {
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
    let steps = opts.steps.unwrap_or(scene.steps);
    let bar = step_bar(steps, &scene.name);
    let profiler = match flamegraph.map(start_profiler).transpose() {
        Ok(p) => p,
        Err(e) => {
            let path = flamegraph.expect("a profiler only for --flamegraph");
            eprintln!("error: --flamegraph {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    };
    let result = run(&scene, opts, |s| {
        if s % 16 == 0 {
            bar.set_position(s);
        }
    });
    bar.finish_and_clear();
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
                // The file was created up front (to fail early on a bad path).
                let _ = std::fs::remove_file(path);
                eprintln!(
                    "warning: --flamegraph {}: no samples (the run was shorter than the \
                     profiler's 1 ms period); no file written: run more --steps",
                    path.display()
                );
            }
            Err(e) => {
                eprintln!("error: --flamegraph {}: {e}", path.display());
                return ExitCode::FAILURE;
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
    if summary.finite {
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
fn note_run(prefix: &str, s: &RunSummary) {
    for w in &s.warnings {
        eprintln!("warning: {prefix}{w}");
    }
    if let Some(w) = &s.energy_warning {
        eprintln!("warning: {prefix}{w}");
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

fn print_table(s: &RunSummary) {
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

/// The scene `arg` names (built-in or file) and the prefix for errors from building it:
/// errors from a scene file name the scene, so the file is prefixed to name it too.
/// `None` after printing the error.
fn resolve_scene(arg: &str) -> Option<(Scene, String)> {
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
fn step_bar(steps: u64, label: &str) -> ProgressBar {
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

/// `phyxel compare`: the scene once per backend, like `run --backend B`.
/// Runs `arg` once per backend of `names`; `(dt, allow_unstable)` are `--dt` and
/// `--allow-unstable`, as for `run`.
fn compare(
    arg: &str,
    names: &[String],
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
    let mut summaries = Vec::with_capacity(names.len());
    for (k, b) in names.iter().enumerate() {
        eprintln!(
            "[{}/{}] {} with backend {b}: {total} steps",
            k + 1,
            names.len(),
            scene.name
        );
        let opts = RunOptions {
            build: BuildOptions {
                backend: Some(b.clone()),
                dt,
                allow_unstable,
                ..Default::default()
            },
            steps,
            ..Default::default()
        };
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
    let blown: Vec<&str> = summaries
        .iter()
        .filter(|s| !s.finite)
        .map(|s| s.backend.as_str())
        .collect();
    for s in &summaries {
        note_run(&format!("backend {}: ", s.backend), s);
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
fn end_energy(s: &RunSummary) -> f64 {
    s.kinetic_energy
        + s.bodies
            .iter()
            .filter_map(|b| b.elastic_energy)
            .sum::<f64>()
}

/// Momentum drift `|p_end − p_start|` (kg·m/s).
fn momentum_drift(s: &RunSummary) -> f64 {
    (0..3)
        .map(|k| (s.momentum_final[k] - s.momentum_initial[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn print_comparison(scene: &Scene, runs: &[RunSummary]) {
    let Some(first) = runs.first() else {
        return;
    };
    println!(
        "scene {}  objects {}  phyxels {}  surfels {}  steps {}",
        first.scene, first.objects, first.phyxels, first.surfels, first.steps
    );
    println!(
        "{:<8} {:>10} {:>9} {:>10} {:>14} {:>14} {:>12} {:>7} {:>9}",
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
            "{:<8} {:>10.3e} {:>9.4} {:>10.1} {:>14.3e} {:>14.3e} {:>12.4e} {:>7} {:>9}",
            s.backend,
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
        print!(" {:>10}", s.backend);
    }
    println!();
    for p in Phase::ALL {
        print!("{:<16}", p.name());
        for s in runs {
            let t = s.phase_seconds.get(p.name()).copied().unwrap_or(0.0);
            print!(" {:>10.4}", 1e3 * t / s.steps.max(1) as f64);
        }
        println!();
    }
}

/// `phyxel validate`: runs the suite, prints the table (or JSON), writes the charts;
/// fails when a row fails.
fn validate(
    quick: bool,
    backend: Option<String>,
    json: bool,
    plot: Option<&Path>,
    only: Option<&str>,
) -> ExitCode {
    use phyxel::app::validate;
    if let Some(b) = &backend
        && let Err(e) = validate::check_backend(b)
    {
        eprintln!("error: {e}");
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
    let mut rows = validate::run_accuracy(&backends, quick, only, report);
    rows.extend(validate::run_stability(&backends, quick, only, report));
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

#[cfg(test)]
mod tests {
    use super::own_time;

    /// `own_time` against a hand count: samples summed per frame across stacks, symbol
    /// hashes left out (two hashes of one function are one frame; a name that only looks
    /// like a hash suffix is kept whole), shares of all samples, largest first, ties by
    /// name, cut to `k`.
    #[test]
    fn own_time_sums_frames_and_ranks_them() {
        let leaves = [
            ("phyxel::body::advect::h0123456789abcdef", 30),
            ("phyxel::contact::detect", 25),
            ("phyxel::body::advect::h1111111111111111", 15),
            ("f32::mul", 25),
            ("a::hnot_a_hash", 5),
        ];
        let own = own_time(leaves.iter().map(|&(f, n)| (f.to_string(), n)), 3);
        assert_eq!(own.samples, 100);
        let top: Vec<(&str, f64)> = own.top.iter().map(|(f, p)| (f.as_str(), *p)).collect();
        assert_eq!(
            top,
            [
                ("phyxel::body::advect", 45.0),
                ("f32::mul", 25.0),
                ("phyxel::contact::detect", 25.0)
            ]
        );
    }
}
