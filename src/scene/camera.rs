//! The scene's camera (`[camera]` in a scene file): where rendered frames look from.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// A pinhole camera: eye position, point looked at, vertical field of view (degrees).
/// In a scene file: `[camera] position = [..], target = [..], fov = 35`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    #[serde(deserialize_with = "crate::io::arrays::exact_array")]
    pub position: [f32; 3],
    #[serde(deserialize_with = "crate::io::arrays::exact_array")]
    pub target: [f32; 3],
    /// Vertical field of view (degrees).
    #[serde(default = "default_fov")]
    pub fov: f32,
    /// World up direction.
    #[serde(
        default = "default_up",
        deserialize_with = "crate::io::arrays::exact_array"
    )]
    pub up: [f32; 3],
}

fn default_fov() -> f32 {
    35.0
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

impl Camera {
    /// A 3/4 view (front, right, above) that fits the box `lo..hi` into a
    /// `width × height` image.
    pub fn fit(lo: Vec3, hi: Vec3, width: u32, height: u32) -> Self {
        let centre = 0.5 * (lo + hi);
        let fov = default_fov();
        let aspect = width as f32 / height.max(1) as f32;
        let tan_v = (0.5 * fov.to_radians()).tan() * 0.9; // 10% margin
        let tan_h = tan_v * aspect;
        let dir = Vec3::new(0.55, 0.45, 1.0).normalize();
        let mut cam = Self {
            position: (centre + dir).to_array(),
            target: centre.to_array(),
            fov,
            up: default_up(),
        };
        let (_, _, right, up) = cam.basis();
        // Nearest eye distance along `dir` at which every box corner is in view.
        let mut dist = 1e-6f32.max(0.5 * (hi - lo).length());
        for k in 0..8 {
            let corner = Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let q = corner - centre;
            let need = q.dot(dir) + (q.dot(right).abs() / tan_h).max(q.dot(up).abs() / tan_v);
            dist = dist.max(need);
        }
        cam.position = (centre + dist * dir).to_array();
        cam
    }

    /// Checks the camera; the message names the bad value.
    pub fn validate(&self) -> Result<(), String> {
        let (eye, target, up) = (
            Vec3::from(self.position),
            Vec3::from(self.target),
            Vec3::from(self.up),
        );
        let (p, t, u) = (self.position, self.target, self.up);
        if !(eye.is_finite() && target.is_finite() && up.is_finite()) {
            return Err(format!(
                "position = {p:?}, target = {t:?}, up = {u:?}: must be finite"
            ));
        }
        if !(self.fov > 1.0 && self.fov < 170.0) {
            return Err(format!("fov = {}: must be in (1, 170) degrees", self.fov));
        }
        let fwd = target - eye;
        // Finite points whose distance (or its square, in `length`) overflows f32.
        if !fwd.length().is_finite() || !up.length().is_finite() {
            return Err(format!(
                "position = {p:?}, target = {t:?}, up = {u:?}: too large for f32 (their \
                 distance overflows); use smaller coordinates (metres)"
            ));
        }
        if fwd.length() < 1e-9 {
            return Err(format!("position = {p:?}, target = {t:?}: they coincide"));
        }
        if fwd.normalize().cross(up).length() < 1e-4 {
            return Err(format!(
                "up = {u:?}: parallel to the view direction from {p:?} to {t:?} (or zero)"
            ));
        }
        Ok(())
    }

    /// The eye and the unit forward, right and up vectors of the view.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3, Vec3) {
        let eye = Vec3::from(self.position);
        let fwd = (Vec3::from(self.target) - eye).normalize();
        let right = fwd.cross(Vec3::from(self.up)).normalize();
        let up = right.cross(fwd);
        (eye, fwd, right, up)
    }

    /// Focal length in pixels for an image `height` pixels high.
    pub fn focal(&self, height: u32) -> f32 {
        0.5 * height as f32 / (0.5 * self.fov.to_radians()).tan()
    }

    /// The eye and the unit direction of the ray through pixel coordinates `(x, y)` of a
    /// `width × height` image (the inverse of [`Camera::project`]): how a window turns
    /// the mouse into a point of the scene.
    pub fn ray(&self, x: f32, y: f32, width: u32, height: u32) -> (Vec3, Vec3) {
        let (eye, fwd, right, up) = self.basis();
        let f = self.focal(height);
        let d = fwd + ((x - 0.5 * width as f32) / f) * right + ((0.5 * height as f32 - y) / f) * up;
        (eye, d.normalize())
    }

    /// The pixel coordinates (x right, y down; pixel centres at +0.5) and view depth of
    /// `p` in a `width × height` image; `None` behind the camera.
    pub fn project(&self, p: Vec3, width: u32, height: u32) -> Option<(f32, f32, f32)> {
        let (eye, fwd, right, up) = self.basis();
        let q = p - eye;
        let z = q.dot(fwd);
        if z <= 1e-6 {
            return None;
        }
        let f = self.focal(height);
        Some((
            0.5 * width as f32 + f * q.dot(right) / z,
            0.5 * height as f32 - f * q.dot(up) / z,
            z,
        ))
    }
}
