//! `phyxel validate`: the validation suite from the command line.

use super::*;

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
/// (the cheap MLS consistency case only; tests/app/validate.rs runs the whole quick suite).
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
