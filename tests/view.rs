//! `phyxel view` draws the live simulation: under Xvfb with Mesa's software OpenGL, a
//! screenshot after N steps shows each body where the engine has it.
//!
//! Reference: the engine's own state through the library (the left sphere's centre of
//! mass is left of the right one's; they touch after 120 steps of `two-spheres`) against
//! pixel statistics of the window (each body's palette colour; the contact colour at the
//! contact's rim, dimmed where a sphere hides it).
//! Needs `xvfb-run` (Debian's xvfb; `.ci/run` installs it) and the `view` feature.
#![cfg(feature = "view")]

use phyxel::app::render::{BACKGROUND, CONTACT_COLOUR, Image, object_colour};
use phyxel::scene::{BuildOptions, Scene};
use std::process::Command;

mod common;

/// Runs the viewer under Xvfb for `after` steps and returns its screenshot.
fn screenshot(after: u64, label: &str) -> Image {
    let path = std::env::temp_dir().join(format!("phyxel-view-{label}-{}.png", std::process::id()));
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1280x1024x24"])
        .arg(env!("CARGO_BIN_EXE_phyxel"))
        .args(["view", "two-spheres", "--size", "640x480", "--after"])
        .arg(after.to_string())
        .arg("--screenshot")
        .arg(&path)
        .output()
        .expect("xvfb-run runs (apt-get install xvfb)");
    assert!(
        out.status.success(),
        "phyxel view failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let image = Image::read_png(&path).expect("screenshot written");
    std::fs::remove_file(&path).ok();
    image
}

/// Pixels within 60 (of 255) per channel of the shaded colour range of `rgb` (lit or in
/// shadow: the hue's channel order is kept), and the mean x of those pixels.
fn pixels_like(image: &Image, rgb: [f32; 3]) -> (usize, f64) {
    let target = rgb.map(|c| c * 255.0);
    let (mut n, mut sx) = (0usize, 0.0f64);
    for y in 0..image.height {
        for x in 0..image.width {
            let p = image.pixel(x, y).map(f32::from);
            // The same hue at any brightness: p ≈ s · target for some s in [0.2, 1.2].
            let s = (p[0] * target[0] + p[1] * target[1] + p[2] * target[2])
                / (target.iter().map(|t| t * t).sum::<f32>());
            if (0.2..=1.2).contains(&s) && (0..3).all(|c| (p[c] - s * target[c]).abs() < 25.0) {
                n += 1;
                sx += x as f64;
            }
        }
    }
    (n, if n > 0 { sx / n as f64 } else { f64::NAN })
}

/// Pixels of a contact seen dimmed through a body: redder than any palette colour (red
/// over green above 0.62; the palette's blues and greens stay near 0.5), blue under 0.8
/// of green (not the background's grey), away from the background (2 pixels: a sphere's
/// anti-aliased edge blends towards grey) and below the heads-up display's band (70 rows).
fn hidden_contact(image: &Image) -> usize {
    let background = |x: i64, y: i64| {
        let (x, y) = (
            x.clamp(0, image.width as i64 - 1),
            y.clamp(0, image.height as i64 - 1),
        );
        let p = image.pixel(x as u32, y as u32);
        (0..3).all(|c| (p[c] as i32 - BACKGROUND[c] as i32).abs() < 40)
    };
    let mut n = 0;
    for y in 70..image.height {
        for x in 0..image.width {
            let [r, g, b] = image.pixel(x, y).map(f32::from);
            let reddened = r > 0.62 * g && r < 1.2 * g && b < 0.8 * g && g > 40.0;
            let inside =
                (-2..=2).all(|dy| (-2..=2).all(|dx| !background(x as i64 + dx, y as i64 + dy)));
            n += usize::from(reddened && inside);
        }
    }
    n
}

#[test]
fn the_window_shows_each_body_where_the_engine_has_it() {
    // The engine's side of the story.
    let mut world = Scene::builtin("two-spheres")
        .unwrap()
        .build(&BuildOptions::default())
        .unwrap();
    for _ in 0..120 {
        world.step();
    }
    let com_x = |k: usize| {
        let p = &world.objects[k].phyxels;
        (0..p.len()).map(|i| p.pos.get(i).x as f64).sum::<f64>() / p.len() as f64
    };
    assert!(com_x(0) < com_x(1));
    assert!(world.record.max_penetration > 0.0, "in contact at step 120");

    let start = screenshot(0, "start");
    let touching = screenshot(120, "touching");
    assert_eq!((touching.width, touching.height), (640, 480));
    let (left, right) = (object_colour(0), object_colour(1));
    for (image, when) in [(&start, "step 0"), (&touching, "step 120")] {
        let (nl, xl) = pixels_like(image, left);
        let (nr, xr) = pixels_like(image, right);
        assert!(
            nl > 1000 && nr > 1000,
            "{when}: both spheres drawn ({nl}, {nr} pixels)"
        );
        assert!(
            xl < xr,
            "{when}: left sphere (x̄ = {xl:.0}) left of the right one ({xr:.0})"
        );
    }
    // The contact surface lies inside the spheres' lens, behind the right sphere's front:
    // drawn dimmed (the right sphere's green reddened), its rim in full.
    let contact_pixels =
        |image: &Image| hidden_contact(image) + pixels_like(image, CONTACT_COLOUR).0;
    let (contact_start, contact) = (contact_pixels(&start), contact_pixels(&touching));
    assert!(
        contact_start < 20,
        "no contact drawn before the spheres meet: {contact_start}"
    );
    assert!(
        contact > 200,
        "the contact surface is drawn at step 120: {contact} pixels"
    );
}

/// Runs `phyxel view ARGS --size 640x480 --json --screenshot FILE` under Xvfb in `dir`;
/// returns the screenshot and the JSON line.
fn view_json(dir: &std::path::Path, args: &[&str], label: &str) -> (Image, serde_json::Value) {
    let path = dir.join(format!("{label}.png"));
    let out = Command::new("xvfb-run")
        .current_dir(dir)
        .args(["-a", "-s", "-screen 0 1280x1024x24"])
        .arg(env!("CARGO_BIN_EXE_phyxel"))
        .arg("view")
        .args(args)
        .args(["--size", "640x480", "--json", "--screenshot"])
        .arg(&path)
        .output()
        .expect("xvfb-run runs (apt-get install xvfb)");
    assert!(
        out.status.success(),
        "phyxel view {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json = serde_json::from_slice(&out.stdout).expect("one JSON line on stdout");
    (Image::read_png(&path).expect("screenshot written"), json)
}

fn vec3(v: &serde_json::Value) -> glam::Vec3 {
    glam::Vec3::from_slice(
        &v.as_array()
            .expect("[x, y, z]")
            .iter()
            .map(|c| c.as_f64().unwrap() as f32)
            .collect::<Vec<_>>(),
    )
}

/// The window pixel of world point `p`, through the camera and image rectangle the
/// viewer reported.
fn to_window(json: &serde_json::Value, p: glam::Vec3) -> (u32, u32) {
    use phyxel::app::render::Camera;
    let c = &json["camera"];
    let cam = Camera {
        position: vec3(&c["position"]).to_array(),
        target: vec3(&c["target"]).to_array(),
        up: vec3(&c["up"]).to_array(),
        fov: c["fov"].as_f64().unwrap() as f32,
    };
    let r: Vec<f32> = json["image"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() as f32)
        .collect();
    let (w, h) = (r[2].round() as u32, r[3].round() as u32);
    let (x, y, _) = cam.project(p, w, h).expect("in front of the camera");
    ((r[0] + x) as u32, (r[1] + y) as u32)
}

/// Share of the pixels of a `half`-wide square around `(x, y)` that have the hue of `rgb`.
fn share_like(image: &Image, (x, y): (u32, u32), half: u32, rgb: [f32; 3]) -> f64 {
    let target = rgb.map(|c| c * 255.0);
    let mut n = 0;
    let mut total = 0;
    for py in y.saturating_sub(half)..=(y + half).min(image.height - 1) {
        for px in x.saturating_sub(half)..=(x + half).min(image.width - 1) {
            let p = image.pixel(px, py).map(f32::from);
            let s = (p[0] * target[0] + p[1] * target[1] + p[2] * target[2])
                / (target.iter().map(|t| t * t).sum::<f32>());
            total += 1;
            if (0.2..=1.2).contains(&s) && (0..3).all(|c| (p[c] - s * target[c]).abs() < 25.0) {
                n += 1;
            }
        }
    }
    n as f64 / total as f64
}

/// Scripted input (`--input docs/view/poke.toml`) brings the tool sphere above the soft
/// ball of `docs/view/anchored-ball.toml` (E = 20 kPa, radius 0.1 m, held by its bottom
/// cap, no gravity) and then sends it 2.8 cm into the ball's top (tool centre at y = 0.1 m, the ball's rest top). The
/// reference is geometry and Newton's third law, not the engine: the tool ends where the
/// script sent it (1e-4 m), it feels the ball pushing it up (reaction along +y, over ten
/// times any sideways component), the ball is dented (its highest surfel at least 5 mm
/// below the rest top, while its anchored bottom stays within 1 mm of y = −0.1), and the
/// screenshot shows the tool's colour at the tool's projected centre and the ball's below
/// it (over half of an 11 × 11 pixel square each).
#[test]
fn scripted_input_moves_the_tool_into_a_soft_ball_and_dents_it() {
    let dir = common::TempDir::new("view", "tool");
    let docs = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/view/");
    let (ball, poke) = (
        format!("{docs}anchored-ball.toml"),
        format!("{docs}poke.toml"),
    );
    let args = [
        ball.as_str(),
        "--input",
        poke.as_str(),
        "--after",
        "600",
        "--speed",
        "0",
    ];
    let (image, json) = view_json(&dir.0, &args, "tool");
    let tool = &json["tool"];
    let centre = vec3(&tool["centre"]);
    assert!(
        (centre - glam::Vec3::new(0.0, 0.1, 0.0)).length() < 1e-4,
        "tool at {centre}"
    );
    let reaction = vec3(&tool["reaction"]);
    assert!(
        reaction.y > 10.0 * reaction.x.abs().max(reaction.z.abs()) && reaction.y > 0.0,
        "the ball pushes the tool up: {reaction} N"
    );
    let ball = &json["objects"][0];
    assert_eq!(ball["name"], "ball");
    let (lo, hi) = (vec3(&ball["min"]), vec3(&ball["max"]));
    assert!(hi.y < 0.1 - 0.005, "the ball's top is dented: {} m", hi.y);
    assert!(
        (lo.y + 0.1).abs() < 1e-3,
        "the anchored bottom stays: {} m",
        lo.y
    );

    let tool_px = to_window(&json, centre);
    let ball_px = to_window(&json, glam::Vec3::new(0.0, -0.02, 0.0));
    let on_tool = share_like(&image, tool_px, 5, object_colour(1));
    let on_ball = share_like(&image, ball_px, 5, object_colour(0));
    assert!(on_tool > 0.5, "tool drawn at {tool_px:?}: {on_tool:.2}");
    assert!(on_ball > 0.5, "ball drawn at {ball_px:?}: {on_ball:.2}");
}

/// A replay of the frames `phyxel run --out` wrote draws the same picture as the live
/// run at the same step: frame 12 of `two-spheres` (every 10 steps) against the live view
/// after 120 steps, same window size. Reference: the live window; at most 0.1% of the
/// image's pixels may differ by more than 8 levels (none do when the frames hold the
/// same state and the camera is fitted to the same first frame).
#[test]
fn a_replay_draws_what_the_live_run_drew() {
    let dir = common::TempDir::new("view", "replay");
    let run = Command::new(env!("CARGO_BIN_EXE_phyxel"))
        .current_dir(&dir.0)
        .args(["run", "two-spheres", "--steps", "120", "--out", "frames"])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let (replay, rj) = view_json(&dir.0, &["--frames", "frames", "--after", "12"], "replay");
    let (live, lj) = view_json(&dir.0, &["two-spheres", "--after", "120"], "live");
    assert_eq!(rj["image"], lj["image"], "the same image rectangle");
    // Not two blank pictures: both spheres are drawn.
    for colour in [object_colour(0), object_colour(1)] {
        assert!(pixels_like(&live, colour).0 > 1000, "a sphere drawn");
    }
    assert_eq!(rj["steps"], 12, "frame 12 shown");
    let r: Vec<u32> = lj["image"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap() as u32)
        .collect();
    let (mut differ, mut total) = (0usize, 0usize);
    for y in r[1]..r[1] + r[3] {
        for x in r[0]..r[0] + r[2] {
            total += 1;
            let (a, b) = (replay.pixel(x, y), live.pixel(x, y));
            differ += (0..3).any(|c| a[c].abs_diff(b[c]) > 8) as usize;
        }
    }
    assert!(
        (differ as f64) <= 1e-3 * total as f64,
        "{differ} of {total} pixels differ"
    );
}

/// Grabbing a finely sampled soft ball (3,000 phyxels) and dragging it sideways pulls it
/// towards the drag, and the state stays finite: the grab spring's damping acts on the
/// few grabbed phyxels only (with the whole ball's mass it makes this ball NaN within
/// 7 steps). Reference: the drag's direction (+x) and finiteness; the ball's centre moves
/// at least 1 mm along +x in 100 steps.
#[test]
fn grabbing_a_fine_ball_pulls_it_and_stays_finite() {
    let dir = common::TempDir::new("view", "grab");
    std::fs::write(
        dir.0.join("grab.toml"),
        "[[event]]\nstep = 0\ngrab = { eye = [0.0, 0.05, 1.0], at = [0.0, 0.05, 0.0] }\n\
         [[event]]\nstep = 1\ndrag = { eye = [0.0, 0.05, 1.0], at = [0.15, 0.05, 0.0] }\n",
    )
    .unwrap();
    let ball = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/view/anchored-ball.toml");
    let args = [
        ball,
        "--phyxel-count",
        "3000",
        "--input",
        "grab.toml",
        "--after",
        "100",
        "--speed",
        "0",
    ];
    let (_, json) = view_json(&dir.0, &args, "grab");
    assert!(json["non_finite"].is_null(), "{}", json["non_finite"]);
    let centre = &json["objects"][0]["centre"];
    assert!(
        centre
            .as_array()
            .unwrap()
            .iter()
            .all(|c| c.as_f64().is_some()),
        "finite centre: {centre}"
    );
    assert!(vec3(centre).x > 1e-3, "pulled towards +x: {centre}");
}

/// Hostile input ends with a message and a failure, never a hang: an event script that
/// names two actions in one event, a replay folder whose only frame is empty (under
/// `--screenshot`), and `--seconds nan`. A script that pauses before the screenshot's
/// step ends the screenshot run at the pause instead of waiting for ever.
#[test]
fn bad_input_fails_with_a_message_and_a_pause_ends_a_screenshot_run() {
    let dir = common::TempDir::new("view", "hostile");
    let run = |args: &[&str]| {
        Command::new("timeout")
            .current_dir(&dir.0)
            .arg("60")
            .arg("xvfb-run")
            .args(["-a", "-s", "-screen 0 1280x1024x24"])
            .arg(env!("CARGO_BIN_EXE_phyxel"))
            .arg("view")
            .args(args)
            .output()
            .unwrap()
    };
    std::fs::write(
        dir.0.join("two.toml"),
        "[[event]]\nstep = 0\nrelease = true\ngravity = false\n",
    )
    .unwrap();
    let out = run(&[
        "two-spheres",
        "--input",
        "two.toml",
        "--screenshot",
        "a.png",
        "--after",
        "5",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("event[0] (step 0): 2 actions"),
        "{err}"
    );

    std::fs::create_dir_all(dir.0.join("odd")).unwrap();
    std::fs::write(dir.0.join("odd/surfels_00000.ply"), "").unwrap();
    let out = run(&["--frames", "odd", "--screenshot", "b.png"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("surfels_00000.ply"),
        "{err}"
    );

    // NaN points are refused: a range check alone passes NaN by (`max_element`), and a
    // NaN tool or drop would panic the simulation thread.
    for event in ["tool = [nan, 0.0, 0.0]", "drop = [nan, 0.5, 0.0]"] {
        std::fs::write(
            dir.0.join("nan.toml"),
            format!("[[event]]\nstep = 0\n{event}\n"),
        )
        .unwrap();
        let out = run(&[
            "two-spheres",
            "--input",
            "nan.toml",
            "--screenshot",
            "n.png",
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.code() == Some(1)
                && err.contains("must be within")
                && !err.contains("panicked"),
            "{event}: {err}"
        );
    }

    // Five drops at one point stacked inside one another: only the first is added.
    let drops: String = (1..=5)
        .map(|k| format!("[[event]]\nstep = {k}\ndrop = [0.0, 0.5, 0.0]\n"))
        .collect();
    std::fs::write(dir.0.join("drops.toml"), drops).unwrap();
    let out = run(&[
        "two-spheres",
        "--input",
        "drops.toml",
        "--screenshot",
        "e.png",
        "--after",
        "8",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let objects = json["objects"].as_array().expect("objects");
    assert_eq!(objects.len(), 3, "two spheres and one drop: {objects:?}");

    // A frame past a replay's last is no frame: refused, not the last one shown.
    let out = run(&["--frames", "odd", "--screenshot", "d.png", "--after", "99"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.code() == Some(1) && err.contains("--after 99"),
        "{err}"
    );

    let out = run(&["two-spheres", "--seconds", "nan"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--seconds NaN"),
        "{err}"
    );

    std::fs::write(
        dir.0.join("pause.toml"),
        "[[event]]\nstep = 3\npause = true\n",
    )
    .unwrap();
    let out = run(&[
        "two-spheres",
        "--input",
        "pause.toml",
        "--screenshot",
        "c.png",
        "--after",
        "50",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["steps"], 3, "stopped at the scripted pause");
}
