//! What `phyxel run` writes: frames, `--contacts`, `--flamegraph`, `--png`, and the checks on their paths.

use super::*;

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

/// Ctrl-C (SIGINT) during `run --out` finishes the step in flight and writes its frame, prints
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
    // Every tenth step's frame and the interrupted step's, each with its contacts.
    let last = u64::from(!steps.is_multiple_of(10));
    assert_eq!(frames.len() as u64, 2 * (steps / 10 + 1 + last));
    for f in frames.iter().filter(|f| f.ends_with(".ply")) {
        assert!(ply_is_whole(&dir.path().join(f)), "{f} is truncated");
    }
}

/// The last step is always written: 25 steps of a scene writing every 10 give frames
/// 0, 1, 2 (steps 0, 10, 20) and 3 (step 25). The manifest names the time step, the
/// frames' format and each frame's simulated time (s): 0, 10 dt, 20 dt and 25 dt
/// (within f32's rounding of the summed time).
#[test]
fn the_last_step_is_a_frame_and_the_manifest_has_times() {
    let dir = TempPath::new("last-frame");
    let v = run_json(&[
        "run",
        "falling-sphere",
        "--steps",
        "25",
        "--json",
        "--out",
        dir.arg(),
    ]);
    assert_eq!(field(&v, "frames_written"), 4, "frames_written");
    assert!(dir.path().join("surfels_00003.ply").is_file());
    let (_, m) = manifest(dir.path());
    let dt = field(&m, "dt").as_f64().expect("dt in the manifest");
    assert_eq!(field(&v, "dt").as_f64().unwrap(), dt);
    assert_eq!(field(&m, "format"), "ply");
    let times: Vec<f64> = field(&m, "times")
        .as_array()
        .expect("times in the manifest")
        .iter()
        .map(|t| t.as_f64().unwrap())
        .collect();
    assert_eq!(times.len(), 4, "{times:?}");
    for (t, steps) in times.iter().zip([0.0, 10.0, 20.0, 25.0]) {
        assert!(
            (t - steps * dt).abs() <= 1e-6 * (steps * dt).max(1e-9),
            "{times:?} vs dt {dt}"
        );
    }
}
