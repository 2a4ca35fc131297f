//! `phyxel run`: the summary (`--json`, the table), options, warnings and interruptions.

use super::*;

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

/// When plastic flow renews a rest shape that is stiffer than the body's start (two
/// plastic, breakable spheres crushed at ±5 m/s; `tests/dynamics/plasticity.rs` checks the
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
/// more lattice volume than the sphere; `sph` keeps the lattice's volumes, the MLS
/// backends fit them to the sphere's) is run, with a warning on stderr naming the
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
        "--backend",
        "sph",
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
