//! Hostile input on the command line (issue 51): outputs that would replace a device, a
//! FIFO, an input or a frame; phyxel frames of bodies whose counts are not a multiple
//! of the SIMD width (a panic); settings a kinematic body ignores; steps accepted above
//! the solver's tolerance. Each test names the class of the cases it pins.
//! The viewer's cases are in `tests/view.rs`, Python's in `tests/python/test_hostile.py`.

use crate::common;

use std::path::Path;
use std::process::{Command, Output};

fn phyxel(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_phyxel"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot start phyxel {args:?}: {e}"))
}

/// Requires exit code 1 (no panic) and every needle on stderr; returns stderr.
fn refused(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let out = phyxel(dir, args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "phyxel {args:?}:\n{err}");
    assert!(
        !err.contains("panicked"),
        "phyxel {args:?} panicked:\n{err}"
    );
    for n in needles {
        assert!(err.contains(n), "phyxel {args:?}: no {n:?} in:\n{err}");
    }
    err
}

fn succeeds(dir: &Path, args: &[&str]) -> Output {
    let out = phyxel(dir, args);
    assert!(
        out.status.success(),
        "phyxel {args:?}: {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[cfg(unix)]
fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(ok.success());
}

#[cfg(unix)]
fn is_fifo(path: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_fifo())
}

/// Data loss: every writer (`render -o`, `--contacts`, `--flamegraph`) refuses a FIFO or
/// a device in place of its file and leaves it as it was; `/dev/null` stays a device.
#[cfg(unix)]
#[test]
fn outputs_refuse_a_fifo_or_a_device() {
    let d = common::TempDir::new("issue51", "special");
    let dir = d.0.as_path();
    succeeds(dir, &["run", "two-spheres", "--steps", "1", "--out", "o"]);
    mkfifo(&dir.join("fifo"));
    let frame = "o/surfels_00000.ply";
    for dest in ["fifo", "/dev/null"] {
        refused(
            dir,
            &["render", frame, "-o", dest],
            &[dest, "not a regular file"],
        );
        for flag in ["--contacts", "--flamegraph"] {
            refused(
                dir,
                &["run", "two-spheres", "--steps", "1", flag, dest],
                &[flag, "not a regular file"],
            );
        }
    }
    assert!(is_fifo(&dir.join("fifo")));
    use std::os::unix::fs::FileTypeExt;
    let null = std::fs::symlink_metadata("/dev/null").unwrap();
    assert!(null.file_type().is_char_device());
}

/// Data loss: `--contacts` may not name the scene file, a frame or the manifest inside
/// `--out`, the `--out` folder itself, or the `--flamegraph` file; the scene file keeps
/// its text and nothing is run.
#[test]
fn contacts_may_not_name_an_input_or_a_run_file() {
    let d = common::TempDir::new("issue51", "contacts");
    let dir = d.0.as_path();
    let scene = succeeds(dir, &["scenes", "--show", "two-spheres"]).stdout;
    std::fs::write(dir.join("victim.toml"), &scene).unwrap();
    let run = ["run", "victim.toml", "--steps", "2"];
    let with = |extra: &[&'static str]| -> Vec<&str> {
        run.iter().chain(extra).copied().collect::<Vec<&str>>()
    };
    refused(
        dir,
        &with(&["--contacts", "victim.toml"]),
        &["--contacts victim.toml", "is the input"],
    );
    refused(
        dir,
        &with(&["--contacts", "./victim.toml"]),
        &["is the input"],
    );
    assert_eq!(std::fs::read(dir.join("victim.toml")).unwrap(), scene);
    std::fs::create_dir(dir.join("o")).unwrap();
    for inside in ["o/surfels_00001.ply", "o/phyxel-manifest.json"] {
        refused(
            dir,
            &with(&["--out", "o", "--contacts", inside]),
            &["inside the --out folder"],
        );
    }
    refused(
        dir,
        &with(&["--out", "o", "--contacts", "o"]),
        &["a directory"],
    );
    refused(
        dir,
        &with(&["--contacts", "c.jsonl", "--flamegraph", "c.jsonl"]),
        &["--flamegraph c.jsonl", "is also the output"],
    );
    // A file of its own name inside `--out` is the user's: allowed.
    succeeds(
        dir,
        &with(&["--out", "o", "--contacts", "o/contacts.jsonl"]),
    );
    let lines = std::fs::read_to_string(dir.join("o/contacts.jsonl")).unwrap();
    assert_eq!(lines.lines().count(), 2);
}

/// Panic: phyxel frames of scenes whose bodies have phyxel counts that are no multiple
/// of the SIMD width (their mass column is padded past the count) are written, with a
/// manifest.
#[test]
fn phyxel_frames_of_any_count_are_written() {
    let d = common::TempDir::new("issue51", "phyxels");
    let dir = d.0.as_path();
    for scene in ["plastic-fracture", "scale"] {
        let out = format!("o-{scene}");
        succeeds(
            dir,
            &["run", scene, "--steps", "1", "--out", &out, "--phyxels"],
        );
        let manifest = std::fs::read_to_string(dir.join(&out).join("phyxel-manifest.json"))
            .expect("a manifest");
        assert!(manifest.contains("phyxels_00000.ply"), "{manifest}");
        let ply = std::fs::read(dir.join(&out).join("phyxels_00000.ply")).unwrap();
        let header = String::from_utf8_lossy(&ply[..ply.len().min(400)]).into_owned();
        assert!(header.contains("property float mass"), "{header}");
    }
}

const TOOL_SCENE: &str = r#"
name = "tool"
dt = 1e-4
steps = 10

[[objects]]
name = "ball"
shape = { type = "sphere", radius = 0.1 }
spacing = 0.025

[[objects]]
name = "tool"
backend = "kinematic"
shape = { type = "sphere", radius = 0.04 }
spacing = 0.02
position = [0.2, 0.0, 0.0]
velocity = [-0.5, 0.0, 0.0]
"#;

/// Silent pass-through: a kinematic body refuses `fixed`, `load` and `self_collision`
/// (which would do nothing, or stretch the rigid tool); the same scene without them runs
/// and writes phyxel frames (its counts, 81 and 88, are odd).
#[test]
fn a_kinematic_body_refuses_settings_that_do_nothing() {
    let d = common::TempDir::new("issue51", "kinematic");
    let dir = d.0.as_path();
    std::fs::write(dir.join("ok.toml"), TOOL_SCENE).unwrap();
    succeeds(
        dir,
        &["run", "ok.toml", "--out", "o", "--phyxels", "--steps", "2"],
    );
    for (extra, key) in [
        (
            "fixed = [{ min = [0.0, -1.0, -1.0], max = [1.0, 1.0, 1.0] }]",
            "objects[1].fixed",
        ),
        ("load = [0.0, -1.0, 0.0]", "objects[1].load"),
        ("self_collision = true", "objects[1].self_collision"),
    ] {
        let text = format!("{TOOL_SCENE}{extra}\n");
        std::fs::write(dir.join("bad.toml"), text).unwrap();
        refused(dir, &["run", "bad.toml"], &["bad.toml", key, "kinematic"]);
    }
}

/// Silent loss: the step whose state goes non-finite ends the contacts stream with a
/// line that says where, and the stream has one line per step run.
/// (`two-spheres` at dt = 3e-3 s, four times its stable bound, blows up by step 30.)
#[test]
fn the_contacts_stream_ends_with_the_non_finite_step() {
    let d = common::TempDir::new("issue51", "nonfinite");
    let dir = d.0.as_path();
    let out = phyxel(
        dir,
        &[
            "run",
            "two-spheres",
            "--steps",
            "60",
            "--dt",
            "0.003",
            "--allow-unstable",
            "--contacts",
            "c.jsonl",
            "--json",
        ],
    );
    assert_eq!(out.status.code(), Some(1));
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let steps = summary["steps"].as_u64().unwrap();
    assert!(steps < 60, "the run blew up: {steps}");
    let text = std::fs::read_to_string(dir.join("c.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len() as u64, steps);
    let last = lines.last().unwrap();
    assert_eq!(last["step"].as_u64(), Some(steps));
    let why = last["non_finite"].as_str().expect("the last line says why");
    assert!(why.contains(&format!("step {steps}")), "{why}");
    assert!(
        lines[..lines.len() - 1]
            .iter()
            .all(|l| l.get("non_finite").is_none())
    );
}
