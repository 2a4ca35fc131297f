//! The splat renderer: `phyxel run --png`, `phyxel render`, and the library API.

use glam::Vec3;
use phyxel::app::render::{BACKGROUND, Camera, Image, RenderOptions, render};
use phyxel::io::frame::Frame;
use phyxel::io::import::read_frame;
use std::path::Path;
use std::process::Command;

use crate::common;
use common::TempDir;

fn phyxel(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_phyxel"))
        .args(args)
        .output()
        .expect("phyxel runs")
}

fn centre(frame: &Frame) -> Vec3 {
    frame.pos.iter().copied().sum::<Vec3>() / frame.len() as f32
}

/// The object's centre is drawn (not background), the corners are background.
fn check_object_at_centre(img: &Image, frame: &Frame, cam: &Camera) {
    let (x, y, _) = cam
        .project(centre(frame), img.width, img.height)
        .expect("centre in front of the camera");
    let (x, y) = (x as u32, y as u32);
    assert!(
        x < img.width && y < img.height,
        "centre projects to ({x}, {y})"
    );
    assert_ne!(img.pixel(x, y), BACKGROUND, "object pixel at ({x}, {y})");
    for (cx, cy) in [(0, 0), (img.width - 1, 0), (0, img.height - 1)] {
        assert_eq!(img.pixel(cx, cy), BACKGROUND, "corner ({cx}, {cy})");
    }
}

/// `phyxel run falling-sphere --steps 10 --out DIR --png --size 320x240`: the first two
/// frames each get a PNG of 320 × 240 pixels, in which the centre of that frame's surfels
/// (their mean position, read back from the frame's PLY), projected with the camera
/// fitted to the first frame's bounds (the run's camera), is drawn (not the background
/// colour), and three of the image's corners are background.
#[test]
fn run_png_writes_one_image_per_frame() {
    let dir = TempDir::new("render", "run");
    let out = dir.0.to_str().unwrap();
    let o = phyxel(&[
        "run",
        "falling-sphere",
        "--steps",
        "10",
        "--out",
        out,
        "--png",
        "--size",
        "320x240",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for k in 0..=1 {
        let png = dir.0.join(format!("surfels_{k:05}.png"));
        let img = Image::read_png(&png).unwrap();
        assert_eq!((img.width, img.height), (320, 240));
        let frame = read_frame(&dir.0.join(format!("surfels_{k:05}.ply"))).unwrap();
        // The run's camera is fitted to the first frame.
        let first = read_frame(&dir.0.join("surfels_00000.ply")).unwrap();
        let (lo, hi) = first.bounds().unwrap();
        check_object_at_centre(&img, &frame, &Camera::fit(lo, hi, 320, 240));
    }
}

/// `phyxel render FRAME.ply -o image.png --size 200x150` on the first frame of a
/// `falling-sphere` run writes a 200 × 150 PNG in which the centre of the frame's surfels,
/// projected with the camera fitted to the frame's bounds, is drawn and three of the
/// image's corners are background.
#[test]
fn render_command_draws_a_frame() {
    let dir = TempDir::new("render", "cmd");
    let out = dir.0.to_str().unwrap();
    let o = phyxel(&["run", "falling-sphere", "--steps", "1", "--out", out]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ply = dir.0.join("surfels_00000.ply");
    let png = dir.0.join("image.png");
    let o = phyxel(&[
        "render",
        ply.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--size",
        "200x150",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let img = Image::read_png(&png).unwrap();
    assert_eq!((img.width, img.height), (200, 150));
    let frame = read_frame(&ply).unwrap();
    let (lo, hi) = frame.bounds().unwrap();
    check_object_at_centre(&img, &frame, &Camera::fit(lo, hi, 200, 150));
}

/// Refusals, each a failing exit status: `render` of a missing frame names its path;
/// `render --size big` names the bad value (`--size big`); `run --png` without `--out`
/// (no directory for the images) is refused.
#[test]
fn render_command_errors_name_the_file() {
    let o = phyxel(&["render", "/nonexistent/frame.ply", "-o", "/tmp/x.png"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("/nonexistent/frame.ply"), "{err}");
    let o = phyxel(&["render", "x.ply", "-o", "/tmp/x.png", "--size", "big"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--size big"));
    let o = phyxel(&["run", "falling-sphere", "--png"]);
    assert!(!o.status.success(), "--png without --out is refused");
}

/// A frame without points is an error naming the file, not a blank image.
#[test]
fn render_refuses_an_empty_frame() {
    let dir = TempDir::new("render", "empty");
    let ply = dir.0.join("empty.ply");
    std::fs::write(
        &ply,
        "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n\
         property float z\nend_header\n",
    )
    .unwrap();
    let png = dir.0.join("empty.png");
    let o = phyxel(&["render", ply.to_str().unwrap(), "-o", png.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("empty.ply") && err.contains("no points"),
        "{err}"
    );
    assert!(!png.exists(), "no image is written");
}

/// A flat square patch of surfels facing +z at `z`, object `id`, contact flag `c`.
fn patch(frame: &mut Frame, x0: f32, z: f32, id: i32, c: u8) {
    for i in 0..20 {
        for j in 0..20 {
            let p = Vec3::new(x0 + 0.05 * i as f32, 0.05 * j as f32 - 0.5, z);
            frame.push(p, Vec3::Z, 0.03, id, c);
        }
    }
}

/// Colours: two 20 × 20 patches of surfels (0.95 m squares side by side, facing a camera
/// 4 m away), both of object 0, the right one flagged as contact. At the left patch's
/// centre the pixel is more blue than red (object 0's colour); at the right one's the red
/// channel is more than twice the blue (the contact highlight); a point 0.9 m up, between
/// and above the patches, is exactly the background colour.
#[test]
fn objects_get_their_colours_and_contact_is_highlighted() {
    let mut frame = Frame::default();
    patch(&mut frame, -1.1, 0.0, 0, 0);
    patch(&mut frame, 0.1, 0.0, 0, 1);
    let cam = Camera {
        position: [0.0, 0.0, 4.0],
        target: [0.0, 0.0, 0.0],
        fov: 40.0,
        up: [0.0, 1.0, 0.0],
    };
    let opts = RenderOptions {
        width: 160,
        height: 120,
        camera: Some(cam),
        ..Default::default()
    };
    let img = render(&frame, &opts);
    let at = |p: Vec3| {
        let (x, y, _) = cam.project(p, 160, 120).unwrap();
        img.pixel(x as u32, y as u32)
    };
    let plain = at(Vec3::new(-0.6, 0.0, 0.0));
    let contact = at(Vec3::new(0.6, 0.0, 0.0));
    // Object 0 is blue, contact red.
    assert!(plain[2] > plain[0], "object colour {plain:?}");
    assert!(contact[0] > 2 * contact[2], "contact colour {contact:?}");
    assert_eq!(at(Vec3::new(0.0, 0.9, 0.0)), BACKGROUND);
}

/// Depth: a blue patch (object 0) 0.5 m in front of a green one (object 1) covering the
/// same area; the pixel at their common centre is more blue than green.
#[test]
fn nearer_splats_hide_farther_ones() {
    let mut frame = Frame::default();
    patch(&mut frame, -0.5, 0.0, 1, 0); // green, behind
    patch(&mut frame, -0.5, 0.5, 0, 0); // blue, in front
    let cam = Camera {
        position: [0.0, 0.0, 4.0],
        target: [0.0, 0.0, 0.0],
        fov: 40.0,
        up: [0.0, 1.0, 0.0],
    };
    let opts = RenderOptions {
        width: 100,
        height: 100,
        camera: Some(cam),
        ..Default::default()
    };
    let img = render(&frame, &opts);
    let (x, y, _) = cam.project(Vec3::new(0.0, 0.0, 0.5), 100, 100).unwrap();
    let c = img.pixel(x as u32, y as u32);
    assert!(c[2] > c[1], "front (blue) object visible: {c:?}");
}

/// `Image::write_png` then `Image::read_png` gives back the same 3 × 2 image, every byte
/// equal.
#[test]
fn png_round_trip() {
    let dir = TempDir::new("render", "png");
    let img = Image {
        width: 3,
        height: 2,
        rgb: (0..18).map(|v| v * 10).collect(),
    };
    let p: &Path = &dir.0.join("a.png");
    img.write_png(p).unwrap();
    assert_eq!(Image::read_png(p).unwrap(), img);
}

/// An honest picture: a contact-flagged patch (object 0) 0.5 m behind a green patch
/// (object 1) covering the same area is dimmed, not drawn as if in front. At their
/// common centre the pixel is more green than red, yet redder than the green patch
/// rendered alone (the contact still shows, dimmed). The same contact patch at the green
/// patch's depth (a contact surface on the surface) is drawn in full: more red than green.
#[test]
fn contact_behind_an_object_is_dimmed_and_on_its_surface_is_not() {
    let cam = Camera {
        position: [0.0, 0.0, 4.0],
        target: [0.0, 0.0, 0.0],
        fov: 40.0,
        up: [0.0, 1.0, 0.0],
    };
    let opts = RenderOptions {
        width: 100,
        height: 100,
        camera: Some(cam),
        ..Default::default()
    };
    let centre = |frame: &Frame| {
        let img = render(frame, &opts);
        let (x, y, _) = cam.project(Vec3::new(0.0, 0.0, 0.5), 100, 100).unwrap();
        img.pixel(x as u32, y as u32)
    };
    let mut alone = Frame::default();
    patch(&mut alone, -0.5, 0.5, 1, 0); // green
    let mut behind = Frame::default();
    patch(&mut behind, -0.5, 0.0, 0, 1); // contact, 0.5 m behind
    patch(&mut behind, -0.5, 0.5, 1, 0);
    let mut on = Frame::default();
    patch(&mut on, -0.5, 0.5, 0, 1); // contact, at the green patch's depth
    patch(&mut on, -0.5, 0.5, 1, 0);
    let (g, b, o) = (centre(&alone), centre(&behind), centre(&on));
    assert!(b[1] > b[0], "hidden contact dimmed: {b:?}");
    assert!(
        b[0] > g[0],
        "hidden contact still shows: {b:?} against {g:?}"
    );
    assert!(o[0] > o[1], "contact on the surface drawn in full: {o:?}");
}

/// A scene's `[camera]` (at (0, 0, 2) m looking at the origin, fov 40°) with a sphere
/// (R = 0.1 m) at x = 0.5 m. `run --png --size 200x100`: the pixel where that camera
/// projects the sphere's centre is drawn and the image centre is background (a fitted
/// camera would centre the sphere). `render --scene` of the same frame gives the same
/// image, byte for byte; `render --scene --fov 20` gives exactly the library's
/// `render` with that camera at fov 20° (and an image different from the 40° one). A
/// scene camera with `fov = 500` is refused by `run`, the message naming `camera` and
/// `fov = 500`.
#[test]
fn scene_camera_is_used_and_checked() {
    let dir = TempDir::new("render", "cam");
    let scene = dir.0.join("cam.toml");
    let body = "steps = 1\n[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\n\
                spacing = 0.025\nposition = [0.5, 0.0, 0.0]\n";
    // Looking at the sphere from the side, off-centre in the image.
    std::fs::write(
        &scene,
        format!("{body}[camera]\nposition = [0.0, 0.0, 2.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40\n"),
    )
    .unwrap();
    let out = dir.0.join("out");
    let o = phyxel(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--png",
        "--size",
        "200x100",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let img = Image::read_png(&out.join("surfels_00000.png")).unwrap();
    let cam = Camera {
        position: [0.0, 0.0, 2.0],
        target: [0.0, 0.0, 0.0],
        fov: 40.0,
        up: [0.0, 1.0, 0.0],
    };
    let (x, y, _) = cam.project(Vec3::new(0.5, 0.0, 0.0), 200, 100).unwrap();
    assert_ne!(img.pixel(x as u32, y as u32), BACKGROUND);
    assert_eq!(img.pixel(100, 50), BACKGROUND, "the image centre is empty");
    // `render --scene` takes the same camera.
    let png = dir.0.join("again.png");
    let o = phyxel(&[
        "render",
        out.join("surfels_00000.ply").to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--size",
        "200x100",
        "--scene",
        scene.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(Image::read_png(&png).unwrap(), img);
    // `--fov` replaces the scene camera's field of view and keeps the rest of it.
    let narrow = dir.0.join("narrow.png");
    let o = phyxel(&[
        "render",
        out.join("surfels_00000.ply").to_str().unwrap(),
        "-o",
        narrow.to_str().unwrap(),
        "--size",
        "200x100",
        "--scene",
        scene.to_str().unwrap(),
        "--fov",
        "20",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let frame = read_frame(&out.join("surfels_00000.ply")).unwrap();
    let expected = render(
        &frame,
        &RenderOptions {
            width: 200,
            height: 100,
            camera: Some(Camera { fov: 20.0, ..cam }),
            ..Default::default()
        },
    );
    assert_eq!(Image::read_png(&narrow).unwrap(), expected);
    assert_ne!(expected, img, "a narrower view changes the image");
    // A bad camera is refused with the field named.
    std::fs::write(
        &scene,
        format!(
            "{body}[camera]\nposition = [0.0, 0.0, 2.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 500\n"
        ),
    )
    .unwrap();
    let o = phyxel(&["run", scene.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("camera") && err.contains("fov = 500"), "{err}");
}

/// A frame whose bounds overflow the fitted camera (a coordinate near f32's limit) is
/// refused naming the frame the camera was fitted to, not an anonymous "camera".
#[test]
fn an_unfittable_frame_is_named() {
    let dir = TempDir::new("render", "huge");
    let mut f = Frame::default();
    f.push(Vec3::ZERO, Vec3::Z, 0.1, 0, 0);
    f.push(Vec3::new(1e38, 0.0, 0.0), Vec3::Z, 0.1, 0, 0);
    let ply = dir.0.join("huge.ply");
    f.write_ply(&ply).unwrap();
    let png = dir.0.join("huge.png");
    let o = phyxel(&["render", ply.to_str().unwrap(), "-o", png.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("camera fitted to") && err.contains("huge.ply") && err.contains("finite"),
        "{err}"
    );
}

/// Degenerate frames still show their points with the fitted camera: one point (its
/// own radius, or none), coincident points and collinear points without radii. The
/// centre pixel is drawn and the corners are background.
#[test]
fn degenerate_frames_are_drawn() {
    let one = |r: f32| {
        let mut f = Frame::default();
        f.push(Vec3::new(0.3, -0.2, 1.0), Vec3::Z, r, 0, 0);
        f
    };
    let mut coincident = Frame::default();
    let mut collinear = Frame::default();
    for i in 0..5 {
        coincident.push(Vec3::ONE, Vec3::Y, 0.0, 0, 0);
        collinear.push(Vec3::new(0.1 * i as f32, 0.0, 0.0), Vec3::ZERO, 0.0, 0, 0);
    }
    let opts = RenderOptions {
        width: 80,
        height: 60,
        ..Default::default()
    };
    for (name, frame) in [
        ("one point", one(0.05)),
        ("one point without radius", one(0.0)),
        ("coincident points", coincident),
        ("collinear points", collinear),
    ] {
        let img = render(&frame, &opts);
        let cam = phyxel::app::render::camera_for(&frame, &opts);
        let (x, y, _) = cam
            .project(centre(&frame), img.width, img.height)
            .unwrap_or_else(|| panic!("{name}: centre behind the camera"));
        assert_ne!(
            img.pixel(x as u32, y as u32),
            BACKGROUND,
            "{name}: centre pixel ({x}, {y}) is background"
        );
        for (cx, cy) in [(0, 0), (img.width - 1, img.height - 1)] {
            assert_eq!(img.pixel(cx, cy), BACKGROUND, "{name}: corner ({cx}, {cy})");
        }
    }
}

/// Samples per pixel drop for images too large to hold them: every size the CLI accepts
/// (16 to 8192 per side) keeps at most `MAX_SAMPLES` samples (32 bytes each, 2 GB), and
/// sizes that fit keep the asked 2 × 2 (an 8192² image at 2 × 2 would take 8.6 GB).
#[test]
fn large_images_take_fewer_samples() {
    use phyxel::app::render::{MAX_SAMPLES, samples_per_axis};
    assert_eq!(samples_per_axis(800, 600, 2), 2);
    assert_eq!(samples_per_axis(4096, 4096, 2), 2);
    assert_eq!(samples_per_axis(8192, 8192, 2), 1);
    assert_eq!(samples_per_axis(8192, 8192, 0), 1);
    for w in [16u32, 1000, 4097, 6000, 8192] {
        for h in [16u32, 3000, 8192] {
            let s = samples_per_axis(w, h, 4);
            let n = u64::from(w) * u64::from(h) * u64::from(s * s);
            assert!(s >= 1 && (n <= MAX_SAMPLES || s == 1), "{w}x{h}: {s}");
        }
    }
}

/// A camera whose points are finite but whose distance overflows f32 (1e30 m: its
/// square is past f32's range) is refused as too large, not as an `up` parallel to the
/// view direction (the overflowed direction makes every `up` look parallel).
#[test]
fn far_cameras_are_refused_as_too_large() {
    let cam = |position: [f32; 3], target: [f32; 3]| Camera {
        position,
        target,
        fov: 35.0,
        up: [0.0, 1.0, 0.0],
    };
    for c in [
        cam([0.0, 0.0, 1e30], [0.0; 3]),
        cam([3e38; 3], [0.0, 1.0, 0.0]),
    ] {
        let e = c.validate().unwrap_err();
        assert!(
            e.contains("too large for f32") && !e.contains("parallel"),
            "{e}"
        );
    }
    assert!(cam([0.0, 0.0, 1e3], [0.0; 3]).validate().is_ok());
}
