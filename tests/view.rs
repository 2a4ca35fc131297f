//! `phyxel view` draws the live simulation: under Xvfb with Mesa's software OpenGL, a
//! screenshot after N steps shows each body where the engine has it.
//!
//! Reference: the engine's own state through the library (the left sphere's centre of
//! mass is left of the right one's; they touch after 120 steps of `two-spheres`) against
//! pixel statistics of the window (each body's palette colour, the contact colour).
//! Needs `xvfb-run` (Debian's xvfb; `.ci/run` installs it) and the `view` feature.
#![cfg(feature = "view")]

use phyxel::app::render::{CONTACT_COLOUR, Image, object_colour};
use phyxel::scene::{BuildOptions, Scene};
use std::process::Command;

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
    let (contact_start, _) = pixels_like(&start, CONTACT_COLOUR);
    let (contact, _) = pixels_like(&touching, CONTACT_COLOUR);
    assert!(
        contact_start < 20,
        "no contact drawn before the spheres meet: {contact_start}"
    );
    assert!(
        contact > 200,
        "the contact surface is drawn at step 120: {contact} pixels"
    );
}
