//! `phyxel compare`: backends side by side, their checks and outputs.

use super::*;

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
