//! The `phyxel` command line: parses the arguments and dispatches to the commands in
//! `cli/` (run, compare, render, scenes, validate).

mod cli;

use cli::compare::compare;
use cli::render::render_frame;
use cli::run::run_scene;
use cli::scenes::scenes;
use cli::validate::validate;

use clap::{Parser, Subcommand};
use phyxel::app::render::RenderOptions;
use phyxel::app::summary::RunOptions;
use phyxel::io::frame::Format;
use phyxel::scene::{BuildOptions, DEFAULT_SCENE, Preset};
use std::path::PathBuf;
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
        /// Remove another run's frames from --out first (without it such a folder is
        /// refused: a shorter run would leave the other run's later frames in it).
        #[arg(long, requires = "out")]
        overwrite: bool,
        /// Also write phyxel PLY frames to --out.
        #[arg(long)]
        phyxels: bool,
        /// Surfel frames hold each body's own surfels in a fixed order (colliding ones
        /// flagged `contact`), not the render surface: point i is the same material
        /// point in every frame until a body fractures.
        #[arg(long, requires = "out")]
        fixed_points: bool,
        /// Also write mesh_NNNNN.ply (or .vtp) per frame: every object's surface as
        /// triangles (a mesh shape's own), their vertices moved with the body.
        #[arg(long, requires = "out")]
        mesh: bool,
        /// File format of the frames in --out: ply (binary PLY), vtk (.vtp and a
        /// frames.pvd series), or usd (one frames.usda stage: every object's mesh, with
        /// --fixed-points its surfels and with --phyxels its phyxels, time-sampled).
        #[arg(long, default_value = "ply", value_parser = ["ply", "vtk", "usd"])]
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
        /// Write each step's contact pairs and their totals (force, torque, area,
        /// centroid, peak pressure, deepest overlap) to this file, one JSON object per line.
        #[arg(long, value_name = "FILE.jsonl")]
        contacts: Option<PathBuf>,
        /// The method's configuration (overrides the scene's `preset`): default, or paper
        /// (the strain JᵀJ − I, influence radius 3 r, contact forces on the resampled
        /// contact surface, spread over two influence radii, pairs handled in order).
        #[arg(long, value_parser = ["default", "paper"])]
        preset: Option<String>,
        /// The memory the scene may need, estimated before it is built: bytes or a size
        /// such as 512M or 8G [default: 80% of the memory available]. A scene estimated
        /// above it is refused with the estimate.
        #[arg(long, value_name = "SIZE", value_parser = phyxel::scene::memory::parse_size)]
        max_memory: Option<u64>,
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
        /// Comma-separated presets; each backend runs once per preset (`default,paper`:
        /// the paper's configuration beside this engine's).
        #[arg(long, value_delimiter = ',', default_value = "default", value_parser = ["default", "paper"])]
        presets: Vec<String>,
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
        /// Comma-separated presets; every case runs once per preset (`default,paper`:
        /// the paper's configuration beside this engine's, rows `mls/paper`).
        #[arg(long, value_delimiter = ',', default_value = "default", value_parser = ["default", "paper"])]
        preset: Vec<String>,
    },
    /// Watch and touch a scene live in a window (feature `view`): the keys are listed at
    /// the window's bottom; `t` brings the tool sphere, ctrl-drag grabs a body
    #[cfg(feature = "view")]
    #[command(allow_negative_numbers = true)]
    View {
        /// Built-in scene name or path to a .toml scene file
        #[arg(default_value = DEFAULT_SCENE)]
        scene: String,
        /// Backend for every deformable object (overrides the scene)
        #[arg(long)]
        backend: Option<String>,
        /// Surfels per deformable object
        #[arg(long = "surfels", value_name = "N")]
        surfels: Option<u32>,
        /// Phyxels per deformable object
        #[arg(long = "phyxel-count", value_name = "N")]
        phyxel_count: Option<u32>,
        /// Window size, WIDTHxHEIGHT
        #[arg(long, default_value = "1280x720")]
        size: String,
        /// Run `--after` steps, draw one frame, save the window as this PNG and exit
        #[arg(long, value_name = "FILE.png")]
        screenshot: Option<PathBuf>,
        /// Steps before the screenshot
        #[arg(long, default_value_t = 0, requires = "screenshot")]
        after: u64,
        /// Close after this many wall seconds (with `--json`: print the run's figures)
        #[arg(long, value_name = "S")]
        seconds: Option<f64>,
        /// Simulated seconds per wall second at most (0: as fast as the machine steps;
        /// `[` and `]` change it live)
        #[arg(long, default_value_t = 1.0, value_name = "X")]
        speed: f64,
        /// Scripted input: a TOML file of [[event]] entries, each applied before its step
        #[arg(long, value_name = "EVENTS.toml")]
        input: Option<PathBuf>,
        /// Play the frames `phyxel run --out DIR` wrote, with a slider (no simulation;
        /// `--after N` then means frame N)
        #[arg(long, value_name = "DIR", conflicts_with_all = ["input", "backend", "surfels", "phyxel_count"])]
        frames: Option<PathBuf>,
        /// Print the state shown (objects, tool, camera) and the run's figures as one JSON
        /// line when the window closes
        #[arg(long)]
        json: bool,
        /// Image pixels per window pixel, in (0, 1] [default: at most 409,600 pixels]
        #[arg(long, value_name = "S")]
        render_scale: Option<f32>,
        /// Simulation threads [default: RAYON_NUM_THREADS, else one less than the cores,
        /// at least 1: the window keeps a core]
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
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

/// Presets named on the command line (clap checked the names); one named twice is an
/// error, as a backend named twice is (`--backends mls,mls`).
fn presets_of(flag: &str, names: &[String]) -> Result<Vec<Preset>, ExitCode> {
    let mut out: Vec<Preset> = Vec::new();
    for n in names {
        let p = Preset::parse(n.trim()).expect("clap checks the value");
        if out.contains(&p) {
            eprintln!("error: {flag}: '{}' is listed twice", n.trim());
            return Err(ExitCode::FAILURE);
        }
        out.push(p);
    }
    Ok(out)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Scenes { show, name } => scenes(show.or(name)),
        #[cfg(feature = "view")]
        Command::View {
            scene,
            backend,
            surfels,
            phyxel_count,
            size,
            screenshot,
            after,
            seconds,
            speed,
            input,
            frames,
            json,
            render_scale,
            threads,
        } => {
            let threads = threads
                .or_else(|| std::env::var("RAYON_NUM_THREADS").ok()?.parse().ok())
                .unwrap_or_else(|| {
                    std::thread::available_parallelism().map_or(1, |n| n.get().saturating_sub(1))
                })
                .max(1);
            if let Some(s) = render_scale
                && !(s > 0.0 && s <= 1.0)
            {
                eprintln!("error: --render-scale {s}: must be in (0, 1]");
                return ExitCode::FAILURE;
            }
            if let Some(s) = seconds
                && !(s.is_finite() && s > 0.0)
            {
                eprintln!("error: --seconds {s}: must be finite and > 0");
                return ExitCode::FAILURE;
            }
            if let Err(e) = cli::view::script::check_speed(speed) {
                eprintln!("error: --speed {speed}: {e}");
                return ExitCode::FAILURE;
            }
            let file =
                (phyxel::scene::Scene::builtin(&scene).is_none()).then(|| PathBuf::from(&scene));
            let scene = match frames {
                Some(_) => None,
                None => match cli::run::resolve_scene(&scene) {
                    Some((scene, _)) => Some(scene),
                    None => return ExitCode::FAILURE,
                },
            };
            let size = match parse_size(&size) {
                Ok(s) => s,
                Err(e) => {
                    eprintln!("error: --size {size}: {e}");
                    return ExitCode::FAILURE;
                }
            };
            let build = BuildOptions {
                backend,
                surfels,
                phyxels: phyxel_count,
                ..BuildOptions::default()
            };
            cli::view::view(
                scene,
                cli::view::ViewOptions {
                    build,
                    size,
                    screenshot,
                    after,
                    seconds,
                    speed,
                    input,
                    frames,
                    json,
                    file,
                    render_scale,
                    threads,
                },
            )
        }
        Command::Validate {
            quick,
            backend,
            json,
            plot,
            case,
            preset,
        } => match presets_of("--preset", &preset) {
            Ok(presets) => validate(
                quick,
                backend,
                json,
                plot.as_deref(),
                case.as_deref(),
                &presets,
            ),
            Err(code) => code,
        },
        Command::Compare {
            scene,
            backends,
            steps,
            json,
            dt,
            allow_unstable,
            presets,
        } => match (
            dt.map(dt_option).transpose(),
            presets_of("--presets", &presets),
        ) {
            (_, Err(code)) => code,
            (Ok(dt), Ok(presets)) => compare(
                &scene,
                &backends,
                &presets,
                steps,
                json,
                (dt, allow_unstable),
            ),
            (Err(e), _) => {
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
            overwrite,
            phyxels,
            fixed_points,
            mesh,
            format,
            png,
            size,
            json,
            allow_unstable,
            surfels,
            phyxel_count,
            flamegraph,
            contacts,
            preset,
            max_memory,
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
            let usd = format == "usd";
            let opts = RunOptions {
                format: if usd {
                    Format::default()
                } else {
                    Format::parse(&format).expect("clap checks the value")
                },
                usd,
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
                    preset: preset.map(|p| Preset::parse(&p).expect("clap checks the value")),
                    max_memory,
                    meshes: mesh || usd,
                },
                steps,
                out,
                phyxels,
                fixed_points,
                mesh,
                contacts,
                overwrite,
                interrupt: None,
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
