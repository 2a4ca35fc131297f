//! End-to-end tests of the `phyxel` command line: they run the built binary and check its
//! output, exit status and error messages. Step counts are kept small so the suite is fast.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

const BUILTINS: [&str; 14] = [
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
    "pile-20",
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

mod compare;
mod outputs;
mod render;
mod run;
mod scene_errors;
mod scenes;
mod validate;
