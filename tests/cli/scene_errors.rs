//! Scene files and options that `phyxel run` refuses: each error names the file, the field and the value.

use super::*;

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

/// A stabilisation weight above `material::MAX_STABILISATION`, or NaN, names the object,
/// the field and the value.
#[test]
fn error_stabilisation_out_of_range() {
    expect_scene_error(
        "stabilisation",
        &format!("{SPHERE}material = {{ stabilisation = 1e3 }}\n"),
        &["objects[0]", "stabilisation = 1000", "at most 100"],
    );
    expect_scene_error(
        "stabilisation-nan",
        &format!("{SPHERE}material = {{ stabilisation = nan }}\n"),
        &["objects[0]", "stabilisation = NaN"],
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

/// An `--out` directory that cannot be made is reported by the flag before the run
/// (`--out DIR` and "cannot create the directory").
#[test]
fn error_out_directory_names_the_flag() {
    expect_error(
        &["run", "--steps", "1", "--out", "/proc/phyxel-out"],
        &["--out /proc/phyxel-out", "cannot create the directory"],
    );
}

/// A mesh drawn in millimetres (a cube 100 units across, read as 100 m) with a 1 cm
/// spacing gives far too many phyxels: the error names the count and points at the
/// mesh's `scale`, with the value that reads it as millimetres (1e-3).
#[test]
fn a_mesh_in_millimetres_points_at_scale() {
    let dir = TempPath::new("mm-mesh");
    std::fs::create_dir_all(dir.path()).unwrap();
    let mut obj = String::new();
    for i in 0..8 {
        let c = |bit: usize| if i >> bit & 1 == 1 { 50.0 } else { -50.0 };
        obj.push_str(&format!("v {} {} {}\n", c(0), c(1), c(2)));
    }
    // Outward-wound faces of the cube (vertex k has x, y, z from its bits 0, 1, 2).
    for f in [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [3, 7, 8, 4],
        [1, 5, 7, 3],
        [2, 4, 8, 6],
    ] {
        obj.push_str(&format!(
            "f {} {} {}\nf {} {} {}\n",
            f[0], f[1], f[2], f[0], f[2], f[3]
        ));
    }
    std::fs::write(dir.path().join("part.obj"), obj).unwrap();
    let scene = dir.path().join("mm.toml");
    std::fs::write(
        &scene,
        "[[objects]]\nshape = { type = \"mesh\", path = \"part.obj\" }\nspacing = 0.01\n",
    )
    .unwrap();
    expect_error(
        &["run", scene.to_str().unwrap(), "--steps", "1"],
        &["phyxels", "spans 100 m", "scale = 1e-3"],
    );
}
