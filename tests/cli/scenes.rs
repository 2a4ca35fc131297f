//! `phyxel scenes` and `phyxel scenes --show`: the built-in scenes.

use super::*;

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

/// `scenes NAME` prints the scene as `scenes --show NAME` does.
#[test]
fn scenes_name_is_show() {
    assert_eq!(
        stdout_of(&["scenes", "two-spheres"]),
        stdout_of(&["scenes", "--show", "two-spheres"])
    );
    expect_error(&["scenes", "nope"], &["unknown scene 'nope'"]);
}
