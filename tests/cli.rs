//! End-to-end tests of the `phyxel` command line: they run the built binary and check its
//! output, exit status and error messages. Step counts are kept small so the suite is fast.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

const BUILTINS: [&str; 13] = [
    "cantilever",
    "falling-sphere",
    "two-spheres",
    "sphere-on-plane",
    "soft-on-plane",
    "pile",
    "newtons-cradle",
    "incline",
    "hertz",
    "scale",
    "plastic-fracture",
    "self-contact",
    "plastic-pile",
];

const PHASES: [&str; 12] = [
    "dynamics",
    "advect",
    "broad_phase",
    "grids",
    "detect",
    "contact_surface",
    "resample",
    "forces",
    "distribute",
    "springs",
    "self_collision",
    "topology",
];

/// A small valid object, for scene files that break one thing at a time.
const SPHERE: &str = "[[objects]]\n\
                      shape = { type = \"sphere\", radius = 0.1 }\n\
                      spacing = 0.025\n";

/// A path under the system temp directory, unique per process and call; removed on drop.
struct TempPath(PathBuf);

impl TempPath {
    fn new(label: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let k = COUNTER.fetch_add(1, Ordering::Relaxed);
        Self(std::env::temp_dir().join(format!("phyxel-cli-{}-{k}-{label}", std::process::id())))
    }

    /// A scene file `<unique>-label.toml` holding `text`.
    fn scene(label: &str, text: &str) -> Self {
        let p = Self::new(&format!("{label}.toml"));
        std::fs::write(&p.0, text).unwrap_or_else(|e| panic!("writing {}: {e}", p.0.display()));
        p
    }

    fn path(&self) -> &Path {
        &self.0
    }

    fn arg(&self) -> &str {
        self.0.to_str().expect("temp paths are UTF-8")
    }
}

impl Drop for TempPath {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn phyxel(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_phyxel"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot start phyxel {args:?}: {e}"))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Runs `phyxel args`, requires success, and returns stdout.
fn stdout_of(args: &[&str]) -> String {
    let out = phyxel(args);
    assert!(
        out.status.success(),
        "phyxel {args:?} failed ({}):\nstderr:\n{}",
        out.status,
        text(&out.stderr)
    );
    text(&out.stdout)
}

/// Runs `phyxel args` (which must include --json), requires success, and parses stdout.
fn run_json(args: &[&str]) -> Value {
    let stdout = stdout_of(args);
    serde_json::from_str(&stdout).unwrap_or_else(|e| {
        panic!("phyxel {args:?}: stdout is not one JSON object ({e}):\n{stdout}")
    })
}

/// Runs `phyxel args`, requires a non-zero exit without a panic and an error message on
/// stderr containing every string in `needles`; returns stderr.
fn expect_error(args: &[&str], needles: &[&str]) -> String {
    let out = phyxel(args);
    let stderr = text(&out.stderr);
    assert!(
        !out.status.success(),
        "phyxel {args:?} should fail but exited with {}:\nstdout:\n{}\nstderr:\n{stderr}",
        out.status,
        text(&out.stdout)
    );
    assert!(
        !stderr.contains("panicked"),
        "phyxel {args:?} panicked instead of reporting an error:\n{stderr}"
    );
    assert_eq!(
        out.status.code(),
        Some(1),
        "phyxel {args:?}: expected exit code 1, stderr:\n{stderr}"
    );
    for needle in needles {
        assert!(
            stderr.contains(needle),
            "phyxel {args:?}: error message lacks {needle:?}:\n{stderr}"
        );
    }
    stderr
}

/// Writes `scene` to a temp file, runs it and expects an error naming the file and `needles`.
fn expect_scene_error(label: &str, scene: &str, needles: &[&str]) -> String {
    let file = TempPath::scene(label, scene);
    let mut all = vec![file.arg()];
    all.extend_from_slice(needles);
    expect_error(&["run", file.arg(), "--steps", "5", "--json"], &all)
}

fn field<'a>(v: &'a Value, key: &str) -> &'a Value {
    v.get(key)
        .unwrap_or_else(|| panic!("summary lacks key {key:?}:\n{v:#}"))
}

/// The header (text up to and including `end_header`) of a PLY file.
fn ply_header(path: &Path) -> String {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    let end = bytes
        .windows(b"end_header\n".len())
        .position(|w| w == b"end_header\n")
        .unwrap_or_else(|| panic!("{}: no end_header line", path.display()));
    text(&bytes[..end + b"end_header\n".len()])
}

/// The N of `element vertex N` in a PLY header.
fn ply_vertex_count(path: &Path) -> u64 {
    let header = ply_header(path);
    assert!(
        header.starts_with("ply\n"),
        "{}: not a PLY file:\n{header}",
        path.display()
    );
    header
        .lines()
        .find_map(|l| l.strip_prefix("element vertex "))
        .unwrap_or_else(|| panic!("{}: no 'element vertex' line:\n{header}", path.display()))
        .trim()
        .parse()
        .unwrap_or_else(|e| panic!("{}: bad vertex count ({e}):\n{header}", path.display()))
}

/// `phyxel scenes` lists every built-in scene, one per line with its description.
#[test]
fn scenes_lists_builtins() {
    let out = stdout_of(&["scenes"]);
    for name in BUILTINS {
        assert!(
            out.lines()
                .any(|l| l.split_whitespace().next() == Some(name)),
            "`phyxel scenes` does not list {name}:\n{out}"
        );
    }
    assert_eq!(
        out.lines().count(),
        BUILTINS.len(),
        "one line per scene:\n{out}"
    );
}

/// `phyxel scenes --show NAME` prints TOML that, run from a file, reproduces the built-in
/// bit for bit: same bodies (com, velocity, mass, counts), phyxels, surfels, dt and final
/// momentum after 10 steps (the simulation is deterministic).
#[test]
fn shown_scenes_reproduce_builtins() {
    for name in BUILTINS {
        let toml = stdout_of(&["scenes", "--show", name]);
        let file = TempPath::scene(name, &toml);
        let from_file = run_json(&["run", file.arg(), "--steps", "10", "--json"]);
        let builtin = run_json(&["run", name, "--steps", "10", "--json"]);
        assert_eq!(
            field(&from_file, "scene"),
            field(&builtin, "scene"),
            "{name}: scene"
        );
        for key in ["bodies", "phyxels", "surfels", "dt", "momentum_final"] {
            // Compare the printed numbers: equal text means bitwise-equal values.
            let a = serde_json::to_string_pretty(field(&from_file, key)).unwrap();
            let b = serde_json::to_string_pretty(field(&builtin, key)).unwrap();
            assert_eq!(
                a,
                b,
                "{name}: `{key}` differs between `run {}` and `run {name}`",
                file.arg()
            );
        }
        assert!(
            !field(&builtin, "bodies").as_array().unwrap().is_empty(),
            "{name}: no bodies"
        );
    }
}

/// `phyxel scenes --show` with an unknown name fails and lists the built-in scenes.
#[test]
fn show_unknown_scene_fails() {
    expect_error(&["scenes", "--show", "nope"], &["nope", "two-spheres"]);
}

/// `phyxel run --steps 5 --json` runs the default scene (two-spheres) and prints one JSON
/// object with the documented keys and consistent counts.
#[test]
fn run_json_default_scene_has_all_keys() {
    let v = run_json(&["run", "--steps", "5", "--json"]);
    assert!(v.is_object(), "not a JSON object:\n{v:#}");
    assert_eq!(field(&v, "scene"), "two-spheres", "default scene");
    assert!(
        field(&v, "backend").is_string(),
        "backend: {}",
        v["backend"]
    );
    assert_eq!(field(&v, "steps"), 5, "steps");
    assert!(
        field(&v, "dt").as_f64().is_some_and(|d| d > 0.0),
        "dt: {}",
        v["dt"]
    );
    for key in ["objects", "surfels", "phyxels"] {
        assert!(
            field(&v, key).as_u64().is_some_and(|n| n > 0),
            "{key}: {}",
            v[key]
        );
    }
    for key in ["wall_seconds", "steps_per_second", "max_penetration"] {
        assert!(
            field(&v, key).as_f64().is_some(),
            "{key} is not a number: {}",
            v[key]
        );
    }
    let phases = field(&v, "phase_seconds")
        .as_object()
        .unwrap_or_else(|| panic!("phase_seconds is not an object: {}", v["phase_seconds"]));
    for p in PHASES {
        assert!(
            phases
                .get(p)
                .and_then(Value::as_f64)
                .is_some_and(|t| t >= 0.0),
            "phase_seconds.{p} missing or not a number >= 0: {phases:?}"
        );
    }
    assert_eq!(field(&v, "finite"), true, "finite");
    assert_eq!(field(&v, "fractures"), 0, "two elastic spheres never break");
    for key in ["momentum_initial", "momentum_final"] {
        let m = field(&v, key).as_array();
        assert!(
            m.is_some_and(|m| m.len() == 3 && m.iter().all(Value::is_number)),
            "{key} is not an array of 3 numbers: {}",
            v[key]
        );
    }
    let bodies = field(&v, "bodies")
        .as_array()
        .unwrap_or_else(|| panic!("bodies is not an array: {}", v["bodies"]));
    assert_eq!(
        bodies.len() as u64,
        v["objects"].as_u64().unwrap(),
        "one body per object"
    );
    for b in bodies {
        for key in [
            "id", "backend", "phyxels", "surfels", "mass", "com", "velocity",
        ] {
            assert!(b.get(key).is_some(), "body lacks {key:?}: {b:#}");
        }
        for key in ["com", "velocity"] {
            assert!(
                b[key].as_array().is_some_and(|a| a.len() == 3),
                "body {key} is not an array of 3: {b:#}"
            );
        }
    }
    for key in ["surfels", "phyxels"] {
        let sum: u64 = bodies.iter().map(|b| b[key].as_u64().unwrap()).sum();
        assert_eq!(
            sum,
            v[key].as_u64().unwrap(),
            "{key}: total != sum over bodies"
        );
    }
}

/// A scene file without `name` is reported under its file stem.
#[test]
fn scene_file_name_defaults_to_file_stem() {
    let file = TempPath::scene("unnamed", SPHERE);
    let v = run_json(&["run", file.arg(), "--steps", "5", "--json"]);
    let stem = file.path().file_stem().unwrap().to_str().unwrap();
    assert_eq!(field(&v, "scene"), stem, "scene name of {}", file.arg());
}

/// `phyxel run` without --json prints a timing table that names every phase.
#[test]
fn run_table_lists_every_phase() {
    let out = stdout_of(&["run", "falling-sphere", "--steps", "5"]);
    for p in PHASES {
        assert!(
            out.lines().any(|l| l.split_whitespace().next() == Some(p)),
            "timing table lacks phase {p}:\n{out}"
        );
    }
    assert!(out.contains("steps/s"), "table lacks the step rate:\n{out}");
}

/// `--out DIR` writes surfels_NNNNN.ply frames (frame 0 plus one per `output.every` steps)
/// whose `element vertex` count equals the summary's surfel count, and a contacts_NNNNN.ply
/// beside each; without --phyxels no phyxel frames are written.
#[test]
fn out_writes_surfel_ply_frames() {
    let dir = TempPath::new("frames");
    let v = run_json(&[
        "run",
        "falling-sphere",
        "--steps",
        "20",
        "--json",
        "--out",
        dir.arg(),
    ]);
    let surfels = field(&v, "surfels").as_u64().unwrap();
    // falling-sphere writes every 10 steps: frames 0, 1, 2.
    for k in 0..3 {
        let f = dir.path().join(format!("surfels_{k:05}.ply"));
        assert!(f.is_file(), "{} was not written", f.display());
        assert_eq!(
            ply_vertex_count(&f),
            surfels,
            "{}: vertex count",
            f.display()
        );
    }
    assert_eq!(field(&v, "frames_written"), 3, "frames_written");
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        !names.iter().any(|n| n.starts_with("phyxels_")),
        "phyxel frames written without --phyxels: {names:?}"
    );
    for k in 0..3 {
        let c = format!("contacts_{k:05}.ply");
        assert!(names.contains(&c), "{c} was not written: {names:?}");
    }
}

/// `--out DIR --phyxels` also writes phyxels_NNNNN.ply with one vertex per phyxel.
#[test]
fn out_with_phyxels_writes_phyxel_frames() {
    let dir = TempPath::new("frames-phyxels");
    let v = run_json(&[
        "run",
        "falling-sphere",
        "--steps",
        "10",
        "--json",
        "--out",
        dir.arg(),
        "--phyxels",
    ]);
    let surfels = field(&v, "surfels").as_u64().unwrap();
    let phyxels = field(&v, "phyxels").as_u64().unwrap();
    for k in 0..2 {
        let s = dir.path().join(format!("surfels_{k:05}.ply"));
        let p = dir.path().join(format!("phyxels_{k:05}.ply"));
        assert_eq!(
            ply_vertex_count(&s),
            surfels,
            "{}: vertex count",
            s.display()
        );
        assert_eq!(
            ply_vertex_count(&p),
            phyxels,
            "{}: vertex count",
            p.display()
        );
    }
}

/// An unknown scene name that is not a file fails and lists the built-in scenes.
#[test]
fn error_unknown_scene_name() {
    expect_error(
        &["run", "no-such-scene", "--steps", "5"],
        &[
            "no-such-scene",
            "two-spheres",
            "falling-sphere",
            "cantilever",
        ],
    );
}

/// A .toml path that does not exist fails and names the file.
#[test]
fn error_missing_scene_file() {
    let file = TempPath::new("missing.toml");
    expect_error(&["run", file.arg(), "--steps", "5"], &[file.arg()]);
}

/// A TOML syntax error names the file and the line.
#[test]
fn error_toml_syntax() {
    expect_scene_error(
        "syntax",
        &format!("{SPHERE}position = [0.0, 1.0\n"),
        &["line"],
    );
}

/// Unknown keys are rejected (not silently ignored) at the top level, in an object and in
/// a material; the message names the file and the key.
#[test]
fn error_unknown_keys() {
    expect_scene_error(
        "unknown-top",
        &format!("gravityy = [0, 0, 0]\n{SPHERE}"),
        &["gravityy"],
    );
    expect_scene_error(
        "unknown-object",
        &format!("{SPHERE}colour = 3\n"),
        &["colour"],
    );
    expect_scene_error(
        "unknown-material",
        &format!("{SPHERE}material = {{ densty = 1000.0 }}\n"),
        &["densty"],
    );
    expect_scene_error(
        "unknown-shape",
        "[[objects]]\nshape = { type = \"cone\", radius = 0.1 }\nspacing = 0.025\n",
        &["cone"],
    );
}

/// A negative sphere radius names the file, the object, the field and the value.
#[test]
fn error_negative_radius() {
    expect_scene_error(
        "radius",
        "[[objects]]\nshape = { type = \"sphere\", radius = -1.0 }\nspacing = 0.025\n",
        &["objects[0]", "radius", "-1"],
    );
}

/// A Poisson ratio of 0.7 (outside (-1, 0.5)) names the object, the field and the value.
#[test]
fn error_poisson_out_of_range() {
    expect_scene_error(
        "poisson",
        &format!("{SPHERE}material = {{ poisson = 0.7 }}\n"),
        &["objects[0]", "poisson", "0.7"],
    );
    // Just inside the range as written, but 0.5 as an f32: the message says why.
    expect_scene_error(
        "poisson-rounded",
        &format!("{SPHERE}material = {{ poisson = 0.49999999 }}\n"),
        &["objects[0]", "poisson = 0.5 (as an f32", "rounds onto it"],
    );
}

/// A zero phyxel spacing names the object, the field and the value; a missing one
/// says what to give.
#[test]
fn error_zero_spacing() {
    expect_scene_error(
        "spacing",
        "[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\nspacing = 0\n",
        &["objects[0]", "spacing = 0"],
    );
    expect_scene_error(
        "no-spacing",
        "[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\n",
        &["objects[0].spacing", "missing", "`phyxels` count"],
    );
}

/// Two objects of one name are refused (messages, summaries and fragments name them).
#[test]
fn error_duplicate_object_names() {
    expect_scene_error(
        "names",
        &format!("{SPHERE}name = \"ball\"\n{SPHERE}name = \"ball\"\nposition = [1.0, 0.0, 0.0]\n"),
        &["objects[1].name", "\"ball\"", "objects[0] has it too"],
    );
}

/// An object name holding a control character (here ESC, a terminal's escape sequence)
/// is refused, and the message shows it escaped: nothing raw reaches the terminal.
#[test]
fn error_control_characters_in_names() {
    let err = expect_scene_error(
        "control",
        &format!("{SPHERE}name = \"red\\u001b[31mball\"\n"),
        &["objects[0].name", "\\u{1b}[31m", "control character"],
    );
    assert!(!err.contains('\u{1b}'), "a raw ESC reached stderr: {err:?}");
}

/// A negative dt in the file names the file, the field and the value.
#[test]
fn error_negative_dt_in_file() {
    expect_scene_error("dt", &format!("dt = -1\n{SPHERE}"), &["dt", "-1"]);
}

/// A non-positive --dt is rejected and the message names the option.
#[test]
fn error_non_positive_dt_option() {
    expect_error(
        &["run", "falling-sphere", "--steps", "5", "--dt=-1"],
        &["--dt", "-1"],
    );
    expect_error(
        &["run", "falling-sphere", "--steps", "5", "--dt", "0"],
        &["--dt", "0"],
    );
    // Too small for f32: reported as given, not as 0.
    expect_error(
        &["run", "falling-sphere", "--steps", "5", "--dt", "1e-50"],
        &["--dt 1e-50", "range"],
    );
}

/// `--dt -1` (space-separated, so it looks like a flag) reaches phyxel's own check
/// instead of clap's "unexpected argument".
#[test]
fn error_negative_dt_option_spaced() {
    expect_error(
        &["run", "falling-sphere", "--steps", "5", "--dt", "-1"],
        &["--dt -1", "must be a finite number > 0"],
    );
}

/// Setting one sampling two ways is an error naming both keys, not a silent choice.
#[test]
fn error_spacing_given_twice() {
    let sphere = "[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\n";
    expect_scene_error(
        "both-spacings",
        &format!("{sphere}spacing = 0.025\nphyxels = 300\n"),
        &["objects[0].phyxels", "spacing", "give one of them"],
    );
    expect_scene_error(
        "both-surfel-spacings",
        &format!("{SPHERE}surfel_spacing = 0.01\nsurfels = 3000\n"),
        &["objects[0].surfels", "surfel_spacing", "give one of them"],
    );
}

/// Numbers beyond the f32 range are refused as written, naming the key, instead of
/// turning into infinity or 0 first.
#[test]
fn error_numbers_beyond_f32() {
    expect_scene_error(
        "huge-density",
        &format!("{SPHERE}material = {{ density = 1e300 }}\n"),
        &["objects[0].material.density", "1e300", "range"],
    );
    expect_scene_error(
        "tiny-dt",
        &format!("dt = 1e-300\n{SPHERE}"),
        &["dt", "1e-300", "range"],
    );
}

/// An object so far from the origin that f32 coordinates there cannot resolve its
/// spacing is refused, naming the position: at 10⁷ m f32 rounds the phyxel spacings to
/// 0, at 5·10⁴ m a body at 1 m/s does not move. 100 m out (f32 steps of 8 µm against a
/// 25 mm spacing) still runs.
#[test]
fn error_position_too_far_for_f32() {
    for far in ["5e4", "1e7"] {
        expect_scene_error(
            &format!("far-{far}"),
            &format!("{SPHERE}position = [{far}, 0.0, 0.0]\n"),
            &["objects[0].position", "too far from the origin", "0.025"],
        );
    }
    let dir = TempPath::new("near");
    std::fs::create_dir_all(&dir.0).unwrap();
    let path = dir.0.join("near.toml");
    std::fs::write(&path, format!("{SPHERE}position = [100.0, 0.0, 0.0]\n")).unwrap();
    stdout_of(&["run", path.to_str().unwrap(), "--steps", "2"]);
}

/// Settings that would silently do nothing are errors: a fixed box that holds no phyxel
/// (the body would be free), plastic flow parameters without a yield stress, plastic flow
/// capped at a `plastic_max` of 0 (no flow) or below f32's strain resolution.
#[test]
fn error_settings_without_effect() {
    expect_scene_error(
        "empty-fixed",
        &format!("{SPHERE}fixed = [{{ min = [5.0, 5.0, 5.0], max = [6.0, 6.0, 6.0] }}]\n"),
        &["objects[0]", "fixed[0]", "holds no phyxel"],
    );
    expect_scene_error(
        "creep-no-yield",
        &format!("{SPHERE}material = {{ plastic_creep = 5.0 }}\n"),
        &["objects[0].material", "plastic_creep = 5", "plastic_yield"],
    );
    expect_scene_error(
        "yield-no-creep",
        &format!("{SPHERE}material = {{ plastic_yield = 0.1 }}\n"),
        &[
            "objects[0].material",
            "plastic_yield = 0.1",
            "plastic_creep = 0",
        ],
    );
    for max in ["0.0", "1e-20"] {
        expect_scene_error(
            "flow-capped",
            &format!(
                "{SPHERE}material = {{ plastic_yield = 0.1, plastic_creep = 5.0, \
                 plastic_max = {max} }}\n"
            ),
            &["objects[0].material", "plastic_max", "plastic flow needs"],
        );
    }
    expect_scene_error(
        "ramp-no-load",
        &format!("{SPHERE}load_ramp = 1.0\n"),
        &["objects[0].load_ramp", "without a load"],
    );
}

/// A body whose `fixed` boxes anchor every phyxel never moves: a `velocity` or `load` on
/// it is refused, naming the key and the value (it would be ignored without a word).
/// Anchoring only part of it keeps them legal.
#[test]
fn error_velocity_or_load_on_a_fully_fixed_body() {
    let all = "fixed = [{ min = [-1.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }]\n";
    for (key, value) in [("velocity", "[1.0, 0.0, 0.0]"), ("load", "[0.0, 0.0, 2.0]")] {
        expect_scene_error(
            "all-fixed",
            &format!("{SPHERE}{key} = {value}\n{all}"),
            &[
                "objects[0]",
                &format!("{key} = {value}"),
                "anchor every phyxel",
            ],
        );
    }
    let part = TempPath::scene(
        "part-fixed",
        &format!(
            "{SPHERE}velocity = [1.0, 0.0, 0.0]\n\
             fixed = [{{ min = [-1.0, -1.0, -1.0], max = [1.0, 0.0, 1.0] }}]\n"
        ),
    );
    stdout_of(&["run", part.arg(), "--steps", "1"]);
}

/// Bodies that start inside one another (phyxels more than a spacing deep) are refused,
/// naming both; touching or barely overlapping ones run.
#[test]
fn error_objects_starting_inside_each_other() {
    let pair = |gap: f32| {
        format!(
            "gravity = [0.0, 0.0, 0.0]\n[[objects]]\nname = \"a\"\n\
             shape = {{ type = \"sphere\", radius = 0.1 }}\nspacing = 0.025\n\
             [[objects]]\nname = \"b\"\nshape = {{ type = \"sphere\", radius = 0.1 }}\n\
             spacing = 0.025\nposition = [{}, 0.0, 0.0]\n",
            0.2 + gap
        )
    };
    expect_scene_error(
        "deep-overlap",
        &pair(-0.1),
        &[
            "objects[0] ('a') starts inside objects[1] ('b')",
            "place them apart",
        ],
    );
    let touching = TempPath::scene("touching", &pair(-0.002));
    stdout_of(&["run", touching.arg(), "--steps", "2"]);
}

/// A plane is solid below its patch only: a ball beside a 0.6 m ground patch, level
/// with it, runs (the plane's contact never reaches it: it falls past the patch freely),
/// while the same ball above the patch but sunk 5 cm into it is refused.
#[test]
fn plane_overlap_is_bounded_by_its_patch() {
    let scene = |x: f32, y: f32| {
        format!(
            "[[objects]]\nname = \"ground\"\nshape = {{ type = \"plane\", size = [0.6, 0.6] }}\n\
             spacing = 0.025\nstatic = true\n\
             [[objects]]\nname = \"ball\"\nshape = {{ type = \"sphere\", radius = 0.1 }}\n\
             spacing = 0.025\nposition = [{x}, {y}, 0.0]\n"
        )
    };
    let beside = TempPath::scene("beside-plane", &scene(1.0, 0.0));
    stdout_of(&["run", beside.arg(), "--steps", "2"]);
    expect_scene_error(
        "sunk-in-plane",
        &scene(0.0, 0.05),
        &["objects[1] ('ball') starts inside objects[0] ('ground')"],
    );
}

/// A friction coefficient above `material::MAX_FRICTION` is refused with the limit.
#[test]
fn error_friction_above_the_limit() {
    expect_scene_error(
        "friction",
        &format!("{SPHERE}material = {{ friction = 1e30 }}\n"),
        &[
            "objects[0].material",
            "friction = 1000000000000000000000000000000",
            "at most 10",
        ],
    );
}

/// A Young's modulus above `material::MAX_YOUNG` (1e37 Pa here, where the stiffness
/// bound overflows f32) is refused with the limit.
#[test]
fn error_young_above_the_limit() {
    expect_scene_error(
        "young",
        &format!("{SPHERE}material = {{ young = 1e37 }}\n"),
        &["objects[0].material", "young = ", "at most 1e15"],
    );
}

/// `volume_stiffness` is bounded like `young`: 1e37 Pa, where the stable bound overflows
/// f32, is refused with the limit, naming the object and the key.
#[test]
fn error_volume_stiffness_above_the_limit() {
    expect_scene_error(
        "volume-stiffness",
        &format!("{SPHERE}material = {{ volume_stiffness = 1e37 }}\n"),
        &[
            "objects[0].material",
            "volume_stiffness = 1e37",
            "at most 1e15",
        ],
    );
}

/// A density outside `material::DENSITY_RANGE` is refused with the range: 1e25 kg/m³
/// (where `sph` goes NaN at step 1) and 1.2e-38 (where the wave speed overflows f32).
#[test]
fn error_density_out_of_range() {
    for (label, density) in [("huge-density", "1e25"), ("tiny-density", "1.2e-38")] {
        expect_scene_error(
            label,
            &format!("{SPHERE}material = {{ density = {density} }}\n"),
            &[
                "objects[0].material",
                &format!("density = {density}"),
                "between 1e-6 and 1e10",
            ],
        );
    }
}

/// Material values each in range whose combination leaves f32's range (a damping of
/// 3e38: the stable bound is 0) are refused naming the object and every value that
/// enters the bound.
#[test]
fn error_material_out_of_range_together() {
    expect_scene_error(
        "huge-damping",
        &format!("{SPHERE}material = {{ damping = 3e38 }}\n"),
        &[
            "no stable time step",
            "damping = 3e38",
            "young = 1e5",
            "phyxel spacing r_i = ",
        ],
    );
}

/// Keys that only act on moving objects (and materials that flow or break) are refused
/// on a static one (naming the key) rather than ignored; `backend` even when it names
/// the default backend.
#[test]
fn error_moving_keys_on_static_object() {
    let plane = "[[objects]]\nshape = { type = \"plane\", size = [1.0, 1.0] }\n\
                 spacing = 0.05\nstatic = true\n";
    for (key, line) in [
        ("velocity", "velocity = [1.0, 0.0, 0.0]"),
        ("backend", "backend = \"sph\""),
        ("backend", "backend = \"mls\""),
        ("load", "load = [0.0, -1.0, 0.0]"),
        ("self_collision", "self_collision = true"),
        ("material", "material = { fracture = true }"),
        (
            "material",
            "material = { plastic_yield = 0.1, plastic_creep = 1.0, plastic_max = 0.2 }",
        ),
    ] {
        expect_scene_error(
            &format!("static-{key}"),
            &format!("{SPHERE}{plane}{line}\n"),
            &[&format!("objects[1].{key}"), "no effect on a static object"],
        );
    }
}

/// A spacing orders of magnitude too fine is refused before sampling (which would take
/// gigabytes) with the estimated count; so are target counts above the limits, from
/// the file or the command line.
#[test]
fn error_sample_counts_beyond_the_limits() {
    expect_scene_error(
        "fine-surfels",
        &format!("{SPHERE}surfel_spacing = 1e-5\n"),
        &["surfel_spacing = 0.00001", "surfels", "limit"],
    );
    expect_scene_error(
        "fine-phyxels",
        "[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\nspacing = 1e-4\n",
        &["spacing = 0.0001", "phyxels", "limit"],
    );
    expect_scene_error(
        "many-phyxels",
        "[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\nphyxels = 100000000\n",
        &["objects[0].phyxels", "100000000", "limit"],
    );
    expect_error(
        &["run", "scale", "--steps", "1", "--surfels", "4000000000"],
        &["--surfels", "4000000000", "limit"],
    );
}

/// A bad --flamegraph path fails before the run, not after it: with a run of 10¹²
/// steps the error can only come first. (Waited for with a deadline, so a regression
/// fails the test instead of hanging it.)
#[test]
fn error_flamegraph_path_before_the_run() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_phyxel"))
        .args([
            "run",
            "falling-sphere",
            "--steps",
            "1000000000000",
            "--flamegraph",
            "/nonexistent-dir/x.svg",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("start phyxel");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait for phyxel") {
            break s;
        }
        if std::time::Instant::now() > deadline {
            child.kill().ok();
            panic!("--flamegraph with a bad path did not fail before the run");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
    assert_eq!(status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("--flamegraph /nonexistent-dir/x.svg"),
        "{stderr}"
    );
}

/// Output options without the output they shape are reported on stderr (the run still
/// succeeds: they are harmless).
#[test]
fn idle_output_options_warn() {
    let out = phyxel(&[
        "run",
        "falling-sphere",
        "--steps",
        "2",
        "--phyxels",
        "--size",
        "320x200",
        "--format",
        "vtk",
    ]);
    let stderr = text(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    for flag in ["--phyxels", "--size", "--format"] {
        assert!(
            stderr.contains(&format!("warning: {flag} has no effect without")),
            "no warning for {flag}:\n{stderr}"
        );
    }
}

/// A heavily damped object gets a small positive stable dt, not 0: the bound
/// `2/ω (√(1+ζ²) − ζ)` is evaluated without cancellation (as written it is 0 in f32 for
/// ζ above about 4000).
#[test]
fn heavy_damping_has_a_positive_stable_dt() {
    let file = TempPath::scene(
        "damped",
        &format!("{SPHERE}material = {{ damping = 1000.0 }}\n"),
    );
    let v = run_json(&["run", file.arg(), "--steps", "2", "--json"]);
    let (dt, bound) = (
        field(&v, "dt").as_f64().unwrap(),
        field(&v, "stable_dt").as_f64().unwrap(),
    );
    assert!(
        bound > 0.0 && dt > 0.0 && dt <= bound,
        "dt {dt}, bound {bound}"
    );
}

/// `--dt` above the stable bound is refused, for every built-in, with a message that
/// mentions the stable bound and suggests a dt; running with the suggested dt (as printed,
/// i.e. rounded) then succeeds.
#[test]
fn error_dt_above_stable_bound_suggests_dt() {
    for name in BUILTINS {
        let stderr = expect_error(
            &["run", name, "--steps", "5", "--dt", "0.01"],
            &["stable", "--dt ", "--allow-unstable"],
        );
        let suggested = stderr
            .split("--dt ")
            .nth(1)
            .and_then(|rest| rest.split_whitespace().next())
            .unwrap_or_else(|| panic!("{name}: no suggested dt after '--dt ':\n{stderr}"));
        suggested.parse::<f32>().unwrap_or_else(|e| {
            panic!("{name}: suggested dt {suggested:?} is not a number ({e}):\n{stderr}")
        });
        let v = run_json(&["run", name, "--steps", "5", "--dt", suggested, "--json"]);
        assert_eq!(
            field(&v, "finite"),
            true,
            "{name}: run at the suggested --dt {suggested}"
        );
    }
}

/// A dt in the file above the stable bound is refused too, naming the file.
#[test]
fn error_dt_in_file_above_stable_bound() {
    expect_scene_error(
        "dt-unstable",
        &format!("dt = 1.0\n{SPHERE}"),
        &["dt", "stable"],
    );
}

/// `--allow-unstable` runs with a dt above the bound instead of refusing it.
#[test]
fn allow_unstable_runs_anyway() {
    let out = phyxel(&[
        "run",
        "falling-sphere",
        "--steps",
        "5",
        "--dt",
        "0.002",
        "--allow-unstable",
        "--json",
    ]);
    let stderr = text(&out.stderr);
    assert!(!stderr.contains("panicked"), "panicked:\n{stderr}");
    let v: Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("no JSON summary ({e}); stderr:\n{stderr}"));
    // dt is an f32, printed as the shortest decimal that reads back as it.
    assert_eq!(
        field(&v, "dt").as_f64().map(|d| d as f32),
        Some(0.002_f32),
        "dt used"
    );
}

/// An unknown backend in the file names the file, the object, the field and the value,
/// and lists the available backends.
#[test]
fn error_unknown_backend_in_file() {
    expect_scene_error(
        "backend",
        &format!("{SPHERE}backend = \"nope\"\n"),
        &["objects[0]", "backend", "nope", "mls"],
    );
}

/// `--backend nope` names the option and the value and lists the available backends.
#[test]
fn error_unknown_backend_option() {
    expect_error(
        &["run", "falling-sphere", "--steps", "5", "--backend", "nope"],
        &["--backend", "nope", "mls"],
    );
}

/// A scene without objects (an empty list, or no `objects` key) is refused, naming the file.
#[test]
fn error_scene_without_objects() {
    expect_scene_error(
        "no-objects",
        "name = \"empty\"\nobjects = []\n",
        &["objects"],
    );
    expect_scene_error("no-objects-key", "name = \"empty\"\n", &["objects"]);
}

/// `run --flamegraph FILE.svg` profiles the run and writes an SVG flamegraph; the run's
/// own output is unchanged, and stderr lists the frames of most own time: at most five,
/// each a share in (0, 100] %, largest first, the shares summing to at most 100%.
#[test]
fn flamegraph_is_written() {
    let path = std::env::temp_dir().join(format!("phyxel-flame-{}.svg", std::process::id()));
    let path_s = path.to_str().unwrap();
    let args = [
        "run",
        "falling-sphere",
        "--steps",
        "200",
        "--flamegraph",
        path_s,
    ];
    let out = phyxel(&args);
    assert!(out.status.success(), "stderr:\n{}", text(&out.stderr));
    let svg = std::fs::read_to_string(&path).expect("flamegraph written");
    assert!(
        svg.starts_with("<?xml") && svg.contains("<svg"),
        "not an SVG: {}",
        &svg[..svg.len().min(200)]
    );
    std::fs::remove_file(&path).ok();
    let stderr = text(&out.stderr);
    let listed = stderr
        .split_once("top frames by own time:\n")
        .unwrap_or_else(|| panic!("no top frames in stderr:\n{stderr}"))
        .1;
    let shares: Vec<f64> = listed
        .lines()
        .map_while(|l| l.trim_start().split_once("%  "))
        .map(|(p, frame)| {
            assert!(
                !frame.trim().is_empty(),
                "a share without a frame: {listed}"
            );
            p.trim().parse().expect("a percentage")
        })
        .collect();
    assert!((1..=5).contains(&shares.len()), "frames listed: {listed}");
    assert!(shares.iter().all(|&p| p > 0.0 && p <= 100.0), "{listed}");
    assert!(
        shares.windows(2).all(|w| w[0] >= w[1]),
        "not ranked: {listed}"
    );
    assert!(shares.iter().sum::<f64>() <= 100.0 + 0.5, "{listed}");
}

/// The scale family: `--surfels N --phyxel-count M` resample every deformable object of
/// `scale` to about N surfels and M phyxels (reference: the requested counts; tolerance
/// 5% for surfels, whose spiral hits the count closely, and 15% for the phyxel lattice,
/// whose count jumps with the boundary rounding); 0 is refused with a message.
#[test]
fn scale_family_sets_sample_counts() {
    let v = run_json(&[
        "run",
        "scale",
        "--surfels",
        "3000",
        "--phyxel-count",
        "120",
        "--steps",
        "2",
        "--json",
    ]);
    let surfels = field(&v, "surfels").as_f64().unwrap();
    let phyxels = field(&v, "phyxels").as_f64().unwrap();
    assert!(
        (surfels / 6000.0 - 1.0).abs() < 0.05,
        "surfels {surfels} for 2 × 3000"
    );
    assert!(
        (phyxels / 240.0 - 1.0).abs() < 0.15,
        "phyxels {phyxels} for 2 × 120"
    );
    expect_error(
        &["run", "scale", "--surfels", "0"],
        &["--surfels 0", "at least one"],
    );
}

/// `compare --json` prints one JSON array with a run summary per backend, in the order
/// given; each summary has exactly the keys of `run --json`, names its backend, and ran
/// the requested number of steps with finite state.
#[test]
fn compare_json_is_an_array_of_run_summaries() {
    let args = [
        "compare",
        "two-spheres",
        "--backends",
        "mls,sph,lj",
        "--steps",
        "3",
        "--json",
    ];
    let stdout = stdout_of(&args);
    let v: Value = serde_json::from_str(&stdout)
        .unwrap_or_else(|e| panic!("compare --json is not JSON ({e}):\n{stdout}"));
    let runs = v.as_array().expect("a JSON array");
    assert_eq!(runs.len(), 3);
    let single = run_json(&["run", "two-spheres", "--steps", "3", "--json"]);
    let keys = |v: &Value| -> Vec<String> {
        let mut k: Vec<String> = v.as_object().expect("object").keys().cloned().collect();
        k.sort();
        k
    };
    for (r, name) in runs.iter().zip(["mls", "sph", "lj"]) {
        assert_eq!(
            keys(r),
            keys(&single),
            "summary keys differ from run --json"
        );
        assert_eq!(field(r, "backend"), name);
        assert_eq!(field(r, "steps"), 3);
        assert_eq!(field(r, "finite"), true);
        for b in field(r, "bodies").as_array().unwrap() {
            assert_eq!(field(b, "backend"), name);
        }
    }
}

/// The `compare` table has a row per backend, the error column ("-": the scene reports
/// no error figure) and every phase of the step.
#[test]
fn compare_table_lists_backends_and_phases() {
    let out = stdout_of(&[
        "compare",
        "falling-sphere",
        "--backends",
        "sph,lj",
        "--steps",
        "2",
    ]);
    for needle in ["backend", "steps/s", "max pen.", "|dp|", "energy", "error"] {
        assert!(out.contains(needle), "table lacks {needle:?}:\n{out}");
    }
    for b in ["sph", "lj"] {
        assert!(
            out.lines()
                .any(|l| l.starts_with(b) && l.trim_end().ends_with('-')),
            "no row for {b}:\n{out}"
        );
    }
    for p in PHASES {
        assert!(out.contains(p), "table lacks phase {p}:\n{out}");
    }
}

/// A bad name in `--backends` exits with 1 before running anything, naming the option,
/// the value and the available backends.
#[test]
fn compare_unknown_backend_fails() {
    expect_error(
        &["compare", "two-spheres", "--backends", "mls,nope"],
        &["--backends", "nope", "mls, mls-implicit, sph, lj"],
    );
}

/// `run --backend sph` and `--backend lj` override every deformable object's backend;
/// the static ground stays static.
#[test]
fn run_with_sph_and_lj_backends() {
    for b in ["sph", "lj"] {
        let v = run_json(&[
            "run",
            "sphere-on-plane",
            "--steps",
            "3",
            "--backend",
            b,
            "--json",
        ]);
        assert_eq!(field(&v, "backend"), b);
        let bodies = field(&v, "bodies").as_array().unwrap();
        assert_eq!(field(&bodies[0], "backend"), "static");
        assert_eq!(field(&bodies[1], "backend"), b);
    }
}

/// `validate --backend nope` is refused before anything runs: it names the option and
/// the value and lists the available backends.
#[test]
fn validate_unknown_backend() {
    let out = phyxel(&["validate", "--quick", "--backend", "nope"]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    for want in ["--backend", "nope", "mls"] {
        assert!(err.contains(want), "stderr lacks '{want}':\n{err}");
    }
}

/// `validate --case NAME` that matches nothing names the value and lists the cases.
#[test]
fn validate_unknown_case() {
    let out = phyxel(&["validate", "--quick", "--case", "nope"]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    for want in ["--case", "nope", "mls-consistency", "stability"] {
        assert!(err.contains(want), "stderr lacks '{want}':\n{err}");
    }
}

/// `validate --quick --json` prints an array of rows with the documented snake_case keys
/// (the cheap MLS consistency case only; tests/validate.rs runs the whole quick suite).
#[test]
fn validate_json_rows() {
    let v: Value = serde_json::from_str(&stdout_of(&[
        "validate",
        "--quick",
        "--json",
        "--case",
        "mls-consistency",
    ]))
    .expect("stdout is a JSON array");
    let rows = v.as_array().expect("an array of rows");
    assert_eq!(rows.len(), 3, "three resolutions: {v}");
    let keys = [
        "case",
        "backend",
        "phyxels",
        "surfels",
        "dt",
        "seconds_per_step",
        "measured",
        "reference",
        "rel_error",
        "tolerance",
        "pass",
    ];
    for r in rows {
        for k in keys {
            assert!(r.get(k).is_some(), "row lacks '{k}': {r}");
        }
        assert_eq!(r["case"], "mls-consistency");
        assert_eq!(r["backend"], "mls");
        assert_eq!(r["pass"], true, "{r}");
        assert!(r["phyxels"].as_u64().unwrap() > 0);
        assert!(r["rel_error"].as_f64().unwrap() < r["tolerance"].as_f64().unwrap());
    }
}

/// `compare hertz` reports the scene's own error figure: the centres' approach against
/// Hertz `δ = (9F²/(16E*²R*))^{1/3}` once the 0.3 s load ramp is over (within 30%: the
/// approach also holds the bulk compression, docs/ACCURACY.md), and `-` before it.
#[test]
fn compare_hertz_reports_the_hertz_error() {
    let error_of = |steps: &str| -> String {
        let out = stdout_of(&["compare", "hertz", "--backends", "mls", "--steps", steps]);
        let row = out
            .lines()
            .find(|l| l.starts_with("mls"))
            .unwrap_or_else(|| panic!("no mls row:\n{out}"));
        row.split_whitespace().last().unwrap().to_string()
    };
    assert_eq!(error_of("10"), "-", "the load is still ramping");
    let e: f64 = error_of("2000").parse().expect("a number after the ramp");
    assert!(e.is_finite() && e < 0.3, "Hertz error {e}");
}

/// A run that blows up stops in the first step whose state is not finite and says
/// where: the step, the object, its backend and the phase; it exits non-zero with the
/// JSON summary still printed, and the same run cut one step earlier reports nothing
/// (the library test `detect.rs::the_first_non_finite_step_is_reported` checks the step
/// against every column).
#[test]
fn a_blow_up_stops_the_run_and_names_where() {
    let args = |steps: &str| {
        phyxel(&[
            "run",
            "falling-sphere",
            "--dt",
            "0.01",
            "--allow-unstable",
            "--steps",
            steps,
            "--json",
        ])
    };
    let out = args("3000");
    assert!(!out.status.success(), "a blown-up run must fail");
    let stderr = text(&out.stderr);
    assert!(!stderr.contains("panicked"), "panicked:\n{stderr}");
    let v: Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("no JSON summary ({e}); stderr:\n{stderr}"));
    assert_eq!(field(&v, "finite").as_bool(), Some(false));
    let ran = field(&v, "steps").as_u64().unwrap();
    assert!(
        (1..3000).contains(&ran),
        "the run did not stop early: {ran} steps"
    );
    let what = field(&v, "non_finite")
        .as_str()
        .unwrap_or_else(|| panic!("{v:#}"));
    for part in [&format!("step {ran}:"), "object 'sphere'", "backend mls"] {
        assert!(what.contains(part), "{what:?} lacks {part:?}");
        assert!(stderr.contains(part), "stderr lacks {part:?}:\n{stderr}");
    }
    // Where: the phase that wrote the first NaN, or the first step whose positions f32
    // no longer resolves (a blow-up reaches it before it overflows).
    assert!(
        ["in the dynamics step", "from the origin"]
            .iter()
            .any(|w| what.contains(w)),
        "{what:?}"
    );
    // (It may still fail: an elastic-energy sum can overflow before the state does.)
    let before = args(&(ran - 1).to_string());
    let v: Value = serde_json::from_slice(&before.stdout).unwrap();
    assert!(field(&v, "non_finite").is_null(), "{v:#}");
}

/// `validate --case NAME` runs exactly the cases whose name starts with NAME: a case that
/// shares a runner with another (`dt-above-bound` with `dt-at-bound`, `incline-slide`
/// with `incline-stick`) is found on its own, and its partner's rows are not printed.
#[test]
fn validate_case_selects_exactly_that_case() {
    for (case, status) in [("dt-above-bound", "refused"), ("incline-slide", "")] {
        let v: Value = serde_json::from_str(&stdout_of(&[
            "validate",
            "--quick",
            "--json",
            "--backend",
            "mls",
            "--case",
            case,
        ]))
        .expect("stdout is a JSON array");
        let rows = v.as_array().unwrap();
        assert!(!rows.is_empty(), "{case}: no rows");
        for r in rows {
            assert_eq!(field(r, "case").as_str(), Some(case), "{r:#}");
            if !status.is_empty() {
                assert_eq!(field(r, "status").as_str(), Some(status), "{r:#}");
            }
        }
    }
}

/// `compare --dt` runs every backend at that dt, and a dt above a backend's bound is
/// refused with the bound's message (whose advice, `--dt` or `--allow-unstable`, compare
/// accepts); `--allow-unstable` runs it anyway.
#[test]
fn compare_takes_dt_and_allow_unstable() {
    let v: Value = serde_json::from_str(&stdout_of(&[
        "compare",
        "two-spheres",
        "--steps",
        "2",
        "--dt",
        "2e-4",
        "--json",
    ]))
    .expect("a JSON array");
    let runs = v.as_array().unwrap();
    assert_eq!(runs.len(), 3);
    for r in runs {
        assert_eq!(field(r, "dt").as_f64().map(|d| d as f32), Some(2e-4_f32));
    }
    expect_error(
        &["compare", "two-spheres", "--steps", "2", "--dt", "0.01"],
        &["stable bound", "--allow-unstable"],
    );
    stdout_of(&[
        "compare",
        "two-spheres",
        "--steps",
        "2",
        "--dt",
        "0.01",
        "--allow-unstable",
        "--backends",
        "mls",
    ]);
}

/// When plastic flow renews a rest shape that is stiffer than the body's start (two
/// plastic, breakable spheres crushed at ±5 m/s; `tests/plasticity.rs` checks the
/// energy), `run` lowers dt below the new bound and says so: `dt_changes` lists each
/// lowering (step, from, to, bound, object), `dt` is the last one's `to`, `time` sums the
/// steps' dt, and stderr notes it. `--allow-unstable` keeps the dt as given (no
/// `dt_changes`). (That run happens to stay bounded, so the energy warning is tested on
/// the cantilever in `an_unstable_dt_gains_energy_and_is_warned`.)
#[test]
fn a_stiffer_rest_shape_lowers_dt_and_says_so() {
    let sphere = |name: &str, x: f32, v: f32| {
        format!(
            "[[objects]]\nname = \"{name}\"\nshape = {{ type = \"sphere\", radius = 0.1 }}\n\
             spacing = 0.025\nposition = [{x}, 0.0, 0.0]\nvelocity = [{v}, 0.0, 0.0]\n\
             material = {{ young = 1e5, plastic_yield = 0.01, plastic_creep = 200.0, \
             plastic_max = 0.3, fracture = true }}\n"
        )
    };
    let scene = TempPath::scene(
        "crush",
        &format!(
            "name = \"crush\"\ngravity = [0.0, 0.0, 0.0]\n{}{}",
            sphere("left", -0.11, 5.0),
            sphere("right", 0.11, -5.0)
        ),
    );
    let file = scene.arg();
    let out = phyxel(&["run", file, "--steps", "40", "--json"]);
    let stderr = text(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let changes = field(&v, "dt_changes").as_array().unwrap();
    assert!(!changes.is_empty(), "no dt change: {v:#}");
    let mut dt0 = None;
    for c in changes {
        let (from, to, bound) = (
            field(c, "from").as_f64().unwrap(),
            field(c, "to").as_f64().unwrap(),
            field(c, "bound").as_f64().unwrap(),
        );
        dt0.get_or_insert(from);
        assert!(to < bound && bound < from, "{c}");
        assert!(field(c, "step").as_u64().unwrap() <= 40, "{c}");
        assert!(field(c, "object").as_str().is_some(), "{c}");
    }
    let last = field(changes.last().unwrap(), "to").as_f64().unwrap();
    assert_eq!(field(&v, "dt").as_f64().unwrap(), last);
    let time = field(&v, "time").as_f64().unwrap();
    assert!(
        time < 40.0 * dt0.unwrap() && time > 40.0 * last,
        "time {time}"
    );
    assert!(stderr.contains("dt lowered from"), "{stderr}");
    assert!(field(&v, "energy_warning").is_null(), "{v:#}");
    let out = phyxel(&["run", file, "--steps", "40", "--json", "--allow-unstable"]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(field(&v, "dt_changes").as_array().map(Vec::len), Some(0));
    assert_eq!(field(&v, "dt").as_f64(), dt0);
}

/// An explicit step above its stable bound blows up with every value finite for a while,
/// which the NaN check cannot see: the energy check must. The cantilever run with
/// `--allow-unstable` at twice its default dt (the default keeps a margin below the
/// stable bound: 1.6× still holds) for 25 steps grows from 0 J (kinetic + elastic +
/// potential + contact, J) to about 6e4 J, still finite (the unstable mode grows from
/// the rest state's rounding, tenfold per step by then; by 30 steps it overflows); at
/// its default dt its mechanical energy stays within 2e-5 J of the start over 50 steps
/// and 1e-3 J over its 10,000 (the sag under gravity, less damping). Reference: energy
/// conservation of a body under gravity alone (it can only lose energy to damping).
/// Asserted: final energy above the initial + 1 J, every value finite, `energy_warning`
/// set, stderr warns; and at the default dt, no warning.
#[test]
fn an_unstable_dt_gains_energy_and_is_warned() {
    let total = |e: &Value| {
        ["kinetic", "elastic", "potential", "contact"]
            .iter()
            .map(|k| field(e, k).as_f64().unwrap())
            .sum::<f64>()
    };
    let run = |extra: &[&str]| {
        let mut args = vec!["run", "cantilever", "--json"];
        args.extend_from_slice(extra);
        let out = phyxel(&args);
        let v: Value = serde_json::from_slice(&out.stdout).unwrap();
        (v, text(&out.stderr))
    };
    let (v, stderr) = run(&["--steps", "50"]);
    assert!(field(&v, "energy_warning").is_null(), "{v:#}");
    assert!(!stderr.contains("energy grew"), "{stderr}");
    let dt = format!("{:e}", 2.0 * field(&v, "dt").as_f64().unwrap());
    let (v, stderr) = run(&["--steps", "25", "--dt", &dt, "--allow-unstable"]);
    assert_eq!(field(&v, "finite").as_bool(), Some(true), "{v:#}");
    let (e0, e1) = (
        total(field(&v, "energy_initial")),
        total(field(&v, "energy_final")),
    );
    assert!(e1 > e0 + 1.0, "no energy gain to warn of: {e0} → {e1} J");
    let warning = field(&v, "energy_warning")
        .as_str()
        .unwrap_or_else(|| panic!("{v:#}"));
    assert!(warning.contains("energy grew"), "{warning}");
    assert!(stderr.contains("warning: the energy grew"), "{stderr}");
}

/// A body sampled too coarsely for its mass (the falling sphere on 20 phyxels holds 52%
/// more lattice volume than the sphere) is run, with a warning on stderr naming the
/// object, and `warnings` in the JSON; at its own spacing the scene has none.
#[test]
fn a_coarse_body_is_run_with_a_warning() {
    let out = phyxel(&[
        "run",
        "falling-sphere",
        "--steps",
        "1",
        "--phyxel-count",
        "20",
        "--json",
    ]);
    let stderr = text(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning:")
            && stderr.contains("'sphere'")
            && stderr.contains("phyxels hold"),
        "{stderr}"
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        field(&v, "warnings").as_array().map(Vec::len),
        Some(1),
        "{v:#}"
    );
    let out = phyxel(&["run", "falling-sphere", "--steps", "1", "--json"]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        field(&v, "warnings").as_array().map(Vec::len),
        Some(0),
        "{v:#}"
    );
    assert!(
        !text(&out.stderr).contains("warning:"),
        "{}",
        text(&out.stderr)
    );
}

/// Negative numbers reach the value checks, which name the flag, instead of reading as
/// an unknown flag (`unexpected argument '-1' found`, quoting `-8` for `-800x600`).
#[test]
fn negative_numbers_name_their_flag() {
    let out = phyxel(&["run", "--steps", "-1"]);
    let e = text(&out.stderr);
    assert!(
        !out.status.success() && e.contains("'-1' for '--steps"),
        "{e}"
    );
    expect_error(&["run", "--dt", "-1"], &["--dt -1", "> 0"]);
    expect_error(
        &["render", "f.ply", "-o", "x.png", "--size", "-800x600"],
        &["--size -800x600", "16 to 8192"],
    );
}

/// `scenes NAME` prints the scene as `scenes --show NAME` does.
#[test]
fn scenes_name_is_show() {
    assert_eq!(
        stdout_of(&["scenes", "two-spheres"]),
        stdout_of(&["scenes", "--show", "two-spheres"])
    );
    expect_error(&["scenes", "nope"], &["unknown scene 'nope'"]);
}

/// `--backends` takes "mls, sph" as "mls,sph" and refuses a backend listed twice.
#[test]
fn compare_backends_are_trimmed_and_unique() {
    let out = phyxel(&[
        "compare",
        "--backends",
        "mls, sph",
        "--steps",
        "2",
        "--json",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let runs: Value = serde_json::from_slice(&out.stdout).expect("a JSON array");
    let names: Vec<&str> = runs
        .as_array()
        .expect("an array")
        .iter()
        .map(|r| r["backend"].as_str().expect("a backend"))
        .collect();
    assert_eq!(names, ["mls", "sph"]);
    expect_error(
        &["compare", "--backends", "mls,mls", "--steps", "1"],
        &["--backends", "'mls' is listed twice"],
    );
}

/// `render` of a `.vtp` frame (what `run --format vtk` writes) says the file is not PLY
/// and how to get PLY frames, not the PLY parser's multi-line dump of expected tokens
/// (`ParseError { .. }`).
#[test]
fn render_of_a_vtk_frame_says_it_is_not_ply() {
    let dir = TempPath::new("vtk-frames");
    stdout_of(&[
        "run",
        "--steps",
        "1",
        "--out",
        dir.arg(),
        "--format",
        "vtk",
        "--json",
    ]);
    let frame = dir.path().join("surfels_00000.vtp");
    let image = dir.path().join("x.png");
    let err = expect_error(
        &[
            "render",
            frame.to_str().expect("UTF-8"),
            "-o",
            image.to_str().expect("UTF-8"),
        ],
        &["surfels_00000.vtp: not a PLY file", "--format ply"],
    );
    assert!(!err.contains("ParseError"), "{err}");
}

/// A run without contact reports its contact energy as 0, not -0 (an empty f64 `sum` is
/// -0.0), in both energies of `run --json`.
#[test]
fn contact_energy_without_contact_is_plus_zero() {
    let v = run_json(&["run", "falling-sphere", "--steps", "2", "--json"]);
    for key in ["energy_initial", "energy_final"] {
        let c = field(field(&v, key), "contact").as_f64().expect("a number");
        assert!(c == 0.0 && c.is_sign_positive(), "{key}.contact = {c:?}");
    }
}

/// An `--out` directory that cannot be made is reported by the flag before the run
/// (`--out DIR` and "cannot create the directory").
#[test]
fn error_out_directory_names_the_flag() {
    expect_error(
        &["run", "--steps", "1", "--out", "/proc/phyxel-out"],
        &["--out /proc/phyxel-out", "cannot create the directory"],
    );
}

/// An `--out` (or `--plot`) path that is an existing file is called "a file, not a
/// directory", without the OS's "File exists".
#[test]
fn error_out_path_that_is_a_file() {
    let file = TempPath::scene("out-file", "not a directory");
    for args in [
        ["run", "--steps", "1", "--out", file.arg()].as_slice(),
        ["validate", "--plot", file.arg()].as_slice(),
    ] {
        let flag = args[args.len() - 2];
        let err = expect_error(
            args,
            &[&format!("{flag} {}", file.arg()), "a file, not a directory"],
        );
        assert!(!err.contains("File exists"), "{err}");
    }
}

/// A run that goes non-finite in its very first step (here a falling sphere at `--dt
/// 1e30 --allow-unstable`: the first step's fall leaves f32's range) is told to look at
/// the scene's sizes and material as well as dt: at the first step a scene whose values
/// leave f32's range together is as likely a cause as the time step.
#[test]
fn a_first_step_blow_up_points_at_the_scene() {
    let scene = TempPath::scene(
        "giant",
        "[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\nspacing = 0.025\n",
    );
    expect_error(
        &[
            "run",
            scene.arg(),
            "--steps",
            "5",
            "--dt",
            "1e30",
            "--allow-unstable",
        ],
        &[
            "step 1:",
            "in its first step",
            "sizes and material",
            "smaller --dt",
        ],
    );
}

/// `compare` on a scene whose objects are all static has nothing to compare (the backends
/// move only moving objects, so every row would be the same, labelled `static`): it is
/// refused with a message naming the file and pointing to `run`, which still runs it.
#[test]
fn compare_refuses_a_scene_without_moving_objects() {
    let scene = TempPath::scene(
        "static-only",
        "name = \"static-only\"\n[[objects]]\nname = \"ground\"\n\
         shape = { type = \"plane\", size = [1.0, 1.0] }\nstatic = true\nspacing = 0.05\n",
    );
    let file = scene.arg();
    expect_error(
        &["compare", file, "--steps", "2"],
        &[file, "every object is static", "phyxel run"],
    );
    let out = phyxel(&["run", file, "--steps", "2", "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
}

/// `run --contacts FILE.jsonl` writes one JSON object per step: its number, time and
/// pairs with the objects' names and the patch totals; the sphere lands on the plane
/// within the run, so some step has a pair carrying a normal force over a positive area.
#[test]
fn run_writes_contact_totals_per_step() {
    let file = TempPath::new("contacts.jsonl");
    stdout_of(&[
        "run",
        "sphere-on-plane",
        "--steps",
        "400",
        "--contacts",
        file.arg(),
    ]);
    let text = std::fs::read_to_string(file.path()).unwrap();
    let lines: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).expect("each line is one JSON object"))
        .collect();
    assert_eq!(lines.len(), 400);
    let mut touched = false;
    for (k, line) in lines.iter().enumerate() {
        assert_eq!(field(line, "step").as_u64(), Some(k as u64 + 1));
        for pair in field(line, "pairs").as_array().unwrap() {
            for key in [
                "a",
                "b",
                "a_name",
                "b_name",
                "contact_surfels",
                "force",
                "normal_force",
                "friction_force",
                "centre",
                "torque",
                "area",
                "centroid",
                "peak_pressure",
                "max_penetration",
            ] {
                field(pair, key);
            }
            touched |= field(pair, "normal_force").as_f64().unwrap() > 0.0
                && field(pair, "area").as_f64().unwrap() > 0.0;
        }
    }
    assert!(touched, "no step with a loaded contact");
    expect_error(
        &[
            "run",
            "sphere-on-plane",
            "--steps",
            "2",
            "--contacts",
            "/nonexistent/dir/c.jsonl",
        ],
        &["--contacts", "/nonexistent/dir/c.jsonl"],
    );
}

/// `run --json` key `contacts`: each pair's history over the run. Reference: Newton's
/// second law. In `two-spheres` the spheres meet and part with no other force on them,
/// so the contact's reported impulse on the left sphere equals its momentum change
/// `m (v₁ − v₀)` (to 1% of the incoming momentum: the impulse sums each step's force
/// times dt). The history is also consistent in itself: mean load at most the peak, the
/// contact times within the run.
#[test]
fn run_json_has_each_pairs_contact_history() {
    let start = run_json(&["run", "two-spheres", "--steps", "0", "--json"]);
    let v = run_json(&["run", "two-spheres", "--steps", "400", "--json"]);
    let contacts = field(&v, "contacts").as_array().unwrap();
    assert_eq!(contacts.len(), 1, "one pair: {contacts:?}");
    let c = &contacts[0];
    assert_eq!(field(c, "a_name"), "left");
    assert_eq!(field(c, "b_name"), "right");
    let body = |v: &Value, k: &str| field(&field(v, "bodies")[0], k).clone();
    let m = body(&v, "mass").as_f64().unwrap();
    let vx = |v: &Value| body(v, "velocity")[0].as_f64().unwrap();
    let change = m * (vx(&v) - vx(&start));
    let impulse = field(c, "impulse")[0].as_f64().unwrap();
    let incoming = m * vx(&start).abs();
    assert!(
        (impulse - change).abs() < 0.01 * incoming,
        "impulse {impulse} N·s against momentum change {change} kg·m/s"
    );
    let num = |k: &str| field(c, k).as_f64().unwrap();
    assert!(num("steps") > 0.0);
    assert!(num("mean_normal_force") <= num("peak_normal_force"));
    assert!(num("mean_normal_force") > 0.0 && num("max_area") > 0.0);
    let time = field(&v, "time").as_f64().unwrap();
    assert!(0.0 < num("first_time") && num("first_time") <= num("last_time"));
    assert!(num("last_time") <= time);
}

/// `--preset`: `run --preset paper` reports `"preset": "paper"` and runs stiffer (the
/// paper's strain is four times stiffer at small strain: a smaller stable dt);
/// `compare --presets default,paper` runs each backend once per preset, rows `mls` and
/// `mls/paper`; an unknown preset is refused naming the flag.
#[test]
fn presets_run_and_compare_side_by_side() {
    let run = |preset: &str| {
        run_json(&[
            "run",
            "two-spheres",
            "--steps",
            "5",
            "--json",
            "--preset",
            preset,
        ])
    };
    let (default, paper) = (run("default"), run("paper"));
    assert_eq!(field(&default, "preset"), "default");
    assert_eq!(field(&paper, "preset"), "paper");
    let dt = |v: &Value| field(v, "stable_dt").as_f64().unwrap();
    assert!(dt(&paper) < dt(&default), "the paper's strain is stiffer");
    let v = run_json(&[
        "compare",
        "two-spheres",
        "--backends",
        "mls",
        "--presets",
        "default,paper",
        "--steps",
        "5",
        "--json",
    ]);
    let presets: Vec<&str> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|s| field(s, "preset").as_str().unwrap())
        .collect();
    assert_eq!(presets, ["default", "paper"]);
    let out = phyxel(&["run", "two-spheres", "--steps", "1", "--preset", "papr"]);
    let err = text(&out.stderr);
    assert!(!out.status.success() && err.contains("--preset") && err.contains("papr"));
}

/// `--flamegraph` to a device (`/dev/full`: every write fails, as on a full disk) is
/// refused before the run, like every output that is not a regular file: the error
/// names the flag and the path, the exit code is 1, nothing runs, and the device is
/// left where it was.
#[test]
fn a_flamegraph_to_a_device_is_refused_before_the_run() {
    let out = phyxel(&[
        "run",
        "two-spheres",
        "--steps",
        "300",
        "--flamegraph",
        "/dev/full",
        "--json",
    ]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "stderr: {err}");
    assert!(out.stdout.is_empty());
    assert!(
        err.contains("--flamegraph /dev/full") && err.contains("not a regular file"),
        "{err}"
    );
    use std::os::unix::fs::FileTypeExt;
    let full = std::fs::symlink_metadata("/dev/full").unwrap();
    assert!(full.file_type().is_char_device());
}

/// Inputs that are not regular files are refused before they are opened: a FIFO as the
/// scene or as `render`'s frame (which would block the open forever), a device (`run
/// /dev/zero`, which never ends), and a mesh linked to `/dev/zero`. A scene file over
/// 16 MiB is refused with its size and the limit (a 50 MB TOML takes 4.1 GB to parse).
#[test]
fn inputs_that_are_not_regular_files_are_refused() {
    let dir = TempPath::new("special");
    std::fs::create_dir_all(dir.path()).unwrap();
    let fifo = dir.path().join("scene.toml");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    let fifo = fifo.to_str().unwrap();
    expect_error(
        &["run", fifo, "--steps", "1"],
        &[fifo, "not a regular file"],
    );
    let png = dir.path().join("x.png");
    expect_error(
        &["render", fifo, "-o", png.to_str().unwrap()],
        &[fifo, "not a regular file"],
    );
    expect_error(
        &["run", "/dev/zero", "--steps", "1"],
        &["/dev/zero", "not a regular file"],
    );

    let mesh = dir.path().join("zero.obj");
    std::os::unix::fs::symlink("/dev/zero", &mesh).unwrap();
    let scene = dir.path().join("mesh.toml");
    std::fs::write(
        &scene,
        "[[objects]]\nshape = { type = \"mesh\", path = \"zero.obj\" }\nspacing = 0.02\n",
    )
    .unwrap();
    expect_error(
        &["run", scene.to_str().unwrap(), "--steps", "1"],
        &["zero.obj", "not a regular file"],
    );

    let big = dir.path().join("big.toml");
    let mut text = String::from("# padding\n");
    text.push_str(&"#".repeat(17 << 20));
    std::fs::write(&big, text).unwrap();
    expect_error(
        &["run", big.to_str().unwrap(), "--steps", "1"],
        &["big.toml", "more than the limit of 16777216 bytes"],
    );
}

/// Whether a binary PLY frame holds all it declares: its length is the header's plus
/// `element vertex N` times the properties' sizes (float and int 4 bytes, uchar 1).
fn ply_is_whole(path: &Path) -> bool {
    let header = ply_header(path);
    let stride: u64 = header
        .lines()
        .filter_map(|l| l.strip_prefix("property "))
        .map(|p| match p.split_whitespace().next() {
            Some("float" | "int") => 4,
            Some("uchar") => 1,
            other => panic!("{}: property type {other:?}", path.display()),
        })
        .sum();
    let len = std::fs::metadata(path).unwrap().len();
    len == header.len() as u64 + ply_vertex_count(path) * stride
}

/// The files of a folder, sorted.
fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// The `frames` of `DIR/phyxel-manifest.json`, sorted, and the manifest.
fn manifest(dir: &Path) -> (Vec<String>, Value) {
    let text = std::fs::read_to_string(dir.join("phyxel-manifest.json")).expect("a manifest");
    let m: Value = serde_json::from_str(&text).expect("JSON");
    let mut frames: Vec<String> = field(&m, "frames")
        .as_array()
        .expect("a list")
        .iter()
        .map(|f| f.as_str().expect("names").to_string())
        .collect();
    frames.sort();
    (frames, m)
}

/// A link planted in the output folder where a frame goes (`ln -s ../victim.txt
/// out/surfels_00001.ply`) is never written through: the folder is refused as holding
/// another run's file, and `--overwrite` removes the link itself, then writes the frame
/// in its place.
#[cfg(unix)]
#[test]
fn a_link_planted_in_the_output_folder_is_not_followed() {
    let base = TempPath::new("planted-link");
    let (out, victim) = (base.path().join("out"), base.path().join("victim.txt"));
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(&victim, "keep").unwrap();
    std::os::unix::fs::symlink("../victim.txt", out.join("surfels_00001.ply")).unwrap();
    let out_arg = out.to_str().unwrap();
    let args = [
        "run",
        "two-spheres",
        "--steps",
        "20",
        "--json",
        "--out",
        out_arg,
    ];
    expect_error(
        &args,
        &[
            "holds 1 file of another run (surfels_00001.ply)",
            "--overwrite",
        ],
    );
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
    let v = run_json(&[&args[..], &["--overwrite"]].concat());
    assert_eq!(field(&v, "frames_written"), 3);
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
    let frame = out.join("surfels_00001.ply");
    assert!(!std::fs::symlink_metadata(&frame).unwrap().is_symlink());
    assert!(ply_is_whole(&frame));
}

/// A shorter second run into the same folder would leave the first run's later frames
/// beside its own. The folder is refused; `--overwrite` clears the other run's files
/// (and only those) first, and the manifest lists exactly the frames on disk.
#[test]
fn another_runs_frames_are_refused_or_cleared() {
    let dir = TempPath::new("stale-frames");
    let notes = dir.path().join("notes.txt");
    let run = |steps: &str, extra: &[&str]| {
        phyxel(
            &[
                &[
                    "run",
                    "falling-sphere",
                    "--steps",
                    steps,
                    "--json",
                    "--out",
                    dir.arg(),
                ][..],
                extra,
            ]
            .concat(),
        )
    };
    assert!(run("30", &[]).status.success());
    std::fs::write(&notes, "mine").unwrap();
    let (frames, m) = manifest(dir.path());
    assert_eq!(frames.len(), 8, "{frames:?}");
    assert_eq!(field(&m, "steps"), 30);
    assert_eq!(field(&m, "interrupted"), false);
    let refused = run("10", &[]);
    assert!(!refused.status.success());
    let err = text(&refused.stderr);
    assert!(
        err.contains("holds 9 files of another run") && err.contains("--overwrite"),
        "{err}"
    );
    assert!(run("10", &["--overwrite"]).status.success());
    let (frames, _) = manifest(dir.path());
    assert_eq!(
        frames,
        [
            "contacts_00000.ply",
            "contacts_00001.ply",
            "surfels_00000.ply",
            "surfels_00001.ply"
        ]
    );
    let mut on_disk = files_in(dir.path());
    on_disk.retain(|n| n != "phyxel-manifest.json" && n != "notes.txt");
    assert_eq!(on_disk, frames);
    assert_eq!(std::fs::read_to_string(&notes).unwrap(), "mine");
}

/// Ctrl-C (SIGINT) during `run --out` finishes the step in flight and its frame, prints
/// the summary with `"interrupted": true` and exits 130. Every frame on disk is whole
/// and listed in the manifest; no temporary file is left.
#[cfg(unix)]
#[test]
fn ctrl_c_finishes_the_frame_prints_the_summary_and_exits_130() {
    /// Kills the run if the test fails before it ends (10 million steps would go on).
    struct Reaper(std::process::Child);
    impl Drop for Reaper {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
    let dir = TempPath::new("ctrl-c");
    let mut child = Reaper(
        Command::new(env!("CARGO_BIN_EXE_phyxel"))
            .args([
                "run",
                "two-spheres",
                "--steps",
                "10000000",
                "--json",
                "--out",
            ])
            .arg(dir.path())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("phyxel starts"),
    );
    let third = dir.path().join("surfels_00003.ply");
    let start = std::time::Instant::now();
    while !third.exists() {
        assert!(
            child.0.try_wait().expect("waits").is_none(),
            "phyxel ended before its third frame"
        );
        assert!(
            start.elapsed().as_secs() < 120,
            "no third frame in 2 minutes"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let sent = Command::new("kill")
        .args(["-INT", &child.0.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(sent.success());
    use std::io::Read;
    let (mut stdout, mut stderr) = (Vec::new(), Vec::new());
    child
        .0
        .stdout
        .take()
        .unwrap()
        .read_to_end(&mut stdout)
        .unwrap();
    child
        .0
        .stderr
        .take()
        .unwrap()
        .read_to_end(&mut stderr)
        .unwrap();
    let status = child.0.wait().expect("phyxel ends");
    let out = Output {
        status,
        stdout,
        stderr,
    };
    assert_eq!(out.status.code(), Some(130), "{}", text(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).expect("the summary on stdout");
    assert_eq!(field(&v, "interrupted"), true);
    let steps = field(&v, "steps").as_u64().unwrap();
    assert!((30..10_000_000).contains(&steps), "steps {steps}");
    let (frames, m) = manifest(dir.path());
    assert_eq!(field(&m, "interrupted"), true);
    assert_eq!(field(&m, "steps").as_u64(), Some(steps));
    let mut on_disk = files_in(dir.path());
    on_disk.retain(|n| n != "phyxel-manifest.json");
    assert_eq!(on_disk, frames, "files on disk against the manifest");
    assert_eq!(frames.len() as u64, 2 * (steps / 10 + 1));
    for f in frames.iter().filter(|f| f.ends_with(".ply")) {
        assert!(ply_is_whole(&dir.path().join(f)), "{f} is truncated");
    }
}

/// A spacing far too fine is blamed for the phyxels it would need (1e-7 m: about 4e18),
/// not on the object's distance from the origin.
#[test]
fn a_spacing_far_too_fine_names_the_phyxel_count() {
    let scene = "[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\nspacing = 1e-7\n\
                 position = [0.0, 0.5, 0.0]\n";
    let err = expect_scene_error(
        "fine-spacing",
        scene,
        &[
            "objects[0].spacing",
            "phyxels, more than the limit of 5000000",
        ],
    );
    assert!(!err.contains("origin"), "{err}");
}

/// A parse error quotes at most 160 characters of its line: a deeply nested array on one
/// line (100,000 brackets) gives an error under 2,000 bytes.
#[test]
fn a_parse_error_quotes_a_long_line_cut() {
    let nested = format!("{SPHERE}position = {}\n", "[".repeat(100_000));
    let err = expect_scene_error("nested", &nested, &["characters)"]);
    assert!(err.len() < 2_000, "{} bytes of error", err.len());
}

/// A body driven out of f32's range during the run (gravity −1e30 m/s²) is stopped and
/// named (`finite: false`, the step, the distance from the origin and gravity), not run
/// on while its motion rounds away with every value finite.
#[test]
fn a_body_leaving_f32_range_during_the_run_stops_it() {
    let scene = TempPath::scene(
        "far-fall",
        &format!("gravity = [0.0, -1e30, 0.0]\n{SPHERE}"),
    );
    let out = phyxel(&["run", scene.arg(), "--steps", "50", "--json"]);
    assert!(!out.status.success());
    let v: Value = serde_json::from_slice(&out.stdout).expect("the summary on stdout");
    assert_eq!(field(&v, "finite"), false);
    let why = field(&v, "non_finite")
        .as_str()
        .expect("a message")
        .to_string();
    for needle in ["step 1:", "from the origin", "gravity"] {
        assert!(why.contains(needle), "{why}");
    }
}

/// At a dt so small that nothing moves (1e-30 s), rounding is no energy gain: the
/// warning's scale is ~0, yet rounding leaves a "gain" of 8e-56 J, and no warning is set.
#[test]
fn rounding_at_a_tiny_dt_is_no_energy_gain() {
    let v = run_json(&[
        "run",
        "falling-sphere",
        "--dt",
        "1e-30",
        "--steps",
        "5",
        "--json",
    ]);
    assert!(
        field(&v, "energy_warning").is_null(),
        "{}",
        v["energy_warning"]
    );
}

/// A `contact_stiffness` so high that its springs set dt far below the bodies' own step
/// is warned of, naming the key (1e30 gives dt = 9.4e-18 s).
#[test]
fn a_contact_stiffness_that_sets_a_tiny_dt_is_warned_of() {
    let scene = TempPath::scene(
        "stiff-contact",
        &format!(
            "{SPHERE}material = {{ contact_stiffness = 1e30 }}\n[[objects]]\nname = \"ground\"\n\
             shape = {{ type = \"plane\", size = [1.0, 1.0] }}\nstatic = true\nspacing = 0.05\n\
             position = [0.0, -0.2, 0.0]\n"
        ),
    );
    let v = run_json(&["run", scene.arg(), "--steps", "1", "--json"]);
    let warnings = field(&v, "warnings").to_string();
    assert!(
        warnings.contains("contact_stiffness = 1e30")
            && warnings.contains("set by the contact springs"),
        "{warnings}"
    );
    let plain = run_json(&["run", "sphere-on-plane", "--steps", "1", "--json"]);
    assert!(
        !field(&plain, "warnings")
            .to_string()
            .contains("contact springs"),
        "{}",
        plain["warnings"]
    );
}

/// A scene whose estimated memory exceeds the budget is refused before it is built,
/// with the estimate, the largest object and the knob. The budget is given here, so the
/// test does not depend on the machine:
/// 1 KiB refuses `two-spheres`; 2 million phyxels per sphere (about 8 GiB each by the
/// model) exceed 1 GiB and fail at once, without sampling anything; 1 GiB runs
/// `two-spheres`. A malformed size is refused by the argument parser.
#[test]
fn run_refuses_a_scene_past_the_memory_budget() {
    expect_error(
        &["run", "two-spheres", "--max-memory", "1K", "--steps", "2"],
        &[
            "two-spheres",
            "needs about",
            "budget of 1.0 KiB",
            "--max-memory",
            "'left'",
        ],
    );
    let started = std::time::Instant::now();
    expect_error(
        &[
            "run",
            "scale",
            "--phyxel-count",
            "2000000",
            "--max-memory",
            "1G",
            "--steps",
            "1",
        ],
        &["needs about", "GiB", "budget of 1.0 GiB (--max-memory)"],
    );
    // Refused from the estimate: building 4 million phyxels takes minutes.
    assert!(started.elapsed().as_secs() < 60);
    let v = run_json(&[
        "run",
        "two-spheres",
        "--max-memory",
        "1G",
        "--steps",
        "2",
        "--json",
    ]);
    assert_eq!(field(&v, "steps").as_u64(), Some(2));
    let out = phyxel(&["run", "two-spheres", "--max-memory", "12Q"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("not a size"));
}
