//! `phyxel render`: frames drawn to images.

use super::*;

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
