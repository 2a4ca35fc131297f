//! `phyxel render`: a PLY frame to a PNG image.

use crate::{parse_size, point};
use phyxel::app::render::{Camera, RenderOptions, camera_for, render};
use phyxel::io::import::read_frame;
use phyxel::scene::Scene;
use std::process::ExitCode;

pub(crate) fn render_frame(
    frame: &std::path::Path,
    out: &std::path::Path,
    size: &str,
    scene: Option<&str>,
    eye: Option<Vec<f32>>,
    target: Option<Vec<f32>>,
    fov: Option<f32>,
) -> ExitCode {
    let result = (|| -> Result<String, String> {
        let (width, height) = parse_size(size).map_err(|e| format!("--size {size}: {e}"))?;
        let surface = read_frame(frame)?;
        if surface.is_empty() {
            return Err(format!("{}: the frame has no points", frame.display()));
        }
        if out
            .extension()
            .is_none_or(|e| !e.eq_ignore_ascii_case("png"))
        {
            eprintln!("warning: -o {}: the image is written as PNG", out.display());
        }
        let mut opts = RenderOptions {
            width,
            height,
            ..Default::default()
        };
        if let Some(s) = scene {
            let scene = Scene::resolve(s).map_err(|e| e.to_string())?;
            if scene.camera.is_none() {
                eprintln!("warning: --scene {s}: the scene has no [camera]; fitting one");
            }
            opts.camera = scene.camera;
        }
        // The scene's camera (or one fitted to the frame), with any of its position,
        // target and field of view replaced by the options given.
        let (eye, target) = (point("eye", eye)?, point("target", target)?);
        let base = camera_for(&surface, &opts);
        let cam = Camera {
            position: eye.unwrap_or(base.position),
            target: target.unwrap_or(base.target),
            fov: fov.unwrap_or(base.fov),
            ..base
        };
        // Say where the camera came from: a fitted one is only as good as the frame's
        // bounds (a coordinate near f32's limit overflows the fit).
        let source = match (
            eye.is_some() || target.is_some() || fov.is_some(),
            scene,
            opts.camera,
        ) {
            (true, _, _) => "the options' camera".to_string(),
            (false, Some(s), Some(_)) => format!("the camera of scene {s}"),
            _ => format!("the camera fitted to {}'s bounds", frame.display()),
        };
        cam.validate().map_err(|e| format!("{source}: {e}"))?;
        opts.camera = Some(cam);
        render(&surface, &opts).write_png(out)?;
        Ok(format!(
            "{}: {} surfels -> {} ({width}x{height})",
            frame.display(),
            surface.len(),
            out.display()
        ))
    })();
    match result {
        Ok(msg) => {
            eprintln!("{msg}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
