//! A headless software splat renderer: surfels drawn as shaded, oriented discs with a
//! depth buffer (ray–disc intersection per pixel), Lambert + ambient lighting, one
//! colour per object and contact surfels highlighted (an overlay, dimmed where objects
//! hide it); supersampled, written as PNG.

use crate::io::frame::Frame;
use glam::Vec3;
#[cfg(feature = "png")]
use std::fs::File;
use std::path::Path;

/// The error of the PNG functions in a build without the `png` feature.
#[cfg(not(feature = "png"))]
fn no_png(path: &Path) -> String {
    format!(
        "{}: phyxel was built without the `png` feature (enable it in Cargo.toml)",
        path.display()
    )
}

/// Background colour (RGB) of every rendered image.
pub const BACKGROUND: [u8; 3] = [236, 239, 243];

/// Colour of contact surfels (flag `contact = 1`).
pub const CONTACT_COLOUR: [f32; 3] = [0.92, 0.16, 0.10];

/// Opacity of the contact overlay where it is visible: contact surfels in front of the
/// objects' surfels (or within two disk radii behind them: they lie on the surface).
pub const CONTACT_ALPHA: f32 = 0.75;

/// Opacity of the contact overlay where an object hides it: dimmed, so that a patch at
/// a body's bottom does not show on its front face as if it were there, yet still shows
/// that a contact is behind.
pub const CONTACT_HIDDEN_ALPHA: f32 = 0.2;

/// Object colours, by object id modulo their count (no reds: red marks contact).
pub const PALETTE: [[f32; 3]; 6] = [
    [0.26, 0.50, 0.86],
    [0.36, 0.70, 0.36],
    [0.93, 0.74, 0.22],
    [0.60, 0.42, 0.80],
    [0.22, 0.70, 0.70],
    [0.62, 0.62, 0.60],
];

/// The colour of contact level `level` (1..=255) when [`RenderOptions::contact_levels`]
/// is set: pale yellow at the lowest, through orange, to deep red at the highest.
pub fn level_colour(level: u8) -> [f32; 3] {
    let t = (f32::from(level.max(1)) - 1.0) / 254.0;
    let (lo, hi) = ([1.0, 0.93, 0.45], [0.62, 0.0, 0.05]);
    std::array::from_fn(|c| lo[c] + t * (hi[c] - lo[c]))
}

/// The colour of object `id`.
pub fn object_colour(id: i32) -> [f32; 3] {
    PALETTE[id.rem_euclid(PALETTE.len() as i32) as usize]
}

pub use crate::scene::camera::Camera;

/// How to render.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    /// Camera; `None`: [`Camera::fit`] to the frame's bounds.
    pub camera: Option<Camera>,
    /// Samples per pixel along each axis (2: 4 samples per pixel), lowered for images
    /// too large to hold them ([`samples_per_axis`]).
    pub supersample: u32,
    /// Disc radius scale over the surfel radius (closes gaps between neighbours).
    pub splat_scale: f32,
    /// Read a contact splat's `contact` value (1..=255) as a level (pressure, say) and
    /// colour it from pale yellow (1) to deep red (255) ([`level_colour`]); otherwise
    /// every contact splat gets [`CONTACT_COLOUR`].
    pub contact_levels: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            width: 800,
            height: 600,
            camera: None,
            supersample: 2,
            splat_scale: 1.2,
            contact_levels: false,
        }
    }
}

/// An 8-bit RGB image, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

impl Image {
    /// The colour of pixel `(x, y)`.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// Writes the image as an 8-bit RGB PNG (an error when built without the `png`
    /// feature).
    #[cfg(not(feature = "png"))]
    pub fn write_png(&self, path: &Path) -> Result<(), String> {
        Err(no_png(path))
    }

    /// Reads an 8-bit RGB or RGBA PNG (an error when built without the `png` feature).
    #[cfg(not(feature = "png"))]
    pub fn read_png(path: &Path) -> Result<Self, String> {
        Err(no_png(path))
    }

    /// Writes the image as an 8-bit RGB PNG.
    #[cfg(feature = "png")]
    pub fn write_png(&self, path: &Path) -> Result<(), String> {
        let name = path.display();
        let mut file = crate::io::atomic::AtomicFile::create(path)
            .map_err(|e| format!("cannot create {e}"))?;
        let mut enc = png::Encoder::new(&mut file, self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::High);
        let mut w = enc
            .write_header()
            .map_err(|e| format!("{name}: writing PNG: {e}"))?;
        w.write_image_data(&self.rgb)
            .map_err(|e| format!("{name}: writing PNG: {e}"))?;
        w.finish()
            .map_err(|e| format!("{name}: writing PNG: {e}"))?;
        file.commit().map_err(|e| e.to_string())
    }

    /// Reads an 8-bit RGB or RGBA PNG (for tests and tools).
    #[cfg(feature = "png")]
    pub fn read_png(path: &Path) -> Result<Self, String> {
        let name = path.display();
        let file = File::open(path).map_err(|e| format!("{name}: cannot open: {e}"))?;
        let mut dec = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .map_err(|e| format!("{name}: reading PNG: {e}"))?;
        let mut buf = vec![0; dec.output_buffer_size().unwrap_or(0)];
        let info = dec
            .next_frame(&mut buf)
            .map_err(|e| format!("{name}: reading PNG: {e}"))?;
        let channels = match info.color_type {
            png::ColorType::Rgb => 3,
            png::ColorType::Rgba => 4,
            c => return Err(format!("{name}: unsupported PNG colour type {c:?}")),
        };
        if info.bit_depth != png::BitDepth::Eight {
            return Err(format!(
                "{name}: unsupported PNG bit depth {:?}",
                info.bit_depth
            ));
        }
        let rgb = buf[..info.buffer_size()]
            .chunks_exact(channels)
            .flat_map(|c| [c[0], c[1], c[2]])
            .collect();
        Ok(Self {
            width: info.width,
            height: info.height,
            rgb,
        })
    }
}

/// The camera `opts` asks for, or one fitted to `frame`.
pub fn camera_for(frame: &Frame, opts: &RenderOptions) -> Camera {
    opts.camera.unwrap_or_else(|| {
        let (lo, hi) = frame
            .bounds()
            .unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
        // The discs stick out of the centres' box: fitting the box alone would put the
        // eye inside the disc of a single point (a blank image).
        let fallback = fallback_radius(frame);
        let pad = (0..frame.len())
            .filter(|&i| frame.pos[i].is_finite())
            .map(|i| disc_radius(frame, i, fallback))
            .fold(0.0f32, f32::max)
            * opts.splat_scale;
        Camera::fit(
            lo - Vec3::splat(pad),
            hi + Vec3::splat(pad),
            opts.width,
            opts.height,
        )
    })
}

/// Disc radius used for points whose frame gives none (m): the frame box's surface area
/// per point; for collinear points the box's diagonal per point, for coincident points
/// [`DEFAULT_RADIUS`].
fn fallback_radius(frame: &Frame) -> f32 {
    let Some((lo, hi)) = frame.bounds() else {
        return DEFAULT_RADIUS;
    };
    let d = hi - lo;
    let n = frame.len().max(1) as f32;
    let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
    let r = (area / n).sqrt() * 0.7;
    let r = if r > 0.0 { r } else { d.length() / n };
    if r > 0.0 && r.is_finite() {
        r
    } else {
        DEFAULT_RADIUS
    }
}

/// Radius of point `i`'s disc before [`RenderOptions::splat_scale`]: its own radius if
/// finite and > 0, else `fallback`.
fn disc_radius(frame: &Frame, i: usize, fallback: f32) -> f32 {
    let r = frame.radius[i];
    if r > 0.0 && r.is_finite() {
        r
    } else {
        fallback
    }
}

/// Disc radius of points without one in a frame whose points all coincide (m).
pub const DEFAULT_RADIUS: f32 = 0.01;

/// Most samples one render keeps (32 bytes each: colour and depth, objects and contact
/// overlay): 2 GB. An 8192 × 8192 image at 2 × 2 samples per pixel needs 8.6 GB; larger
/// images get fewer samples per pixel, down to one.
pub const MAX_SAMPLES: u64 = 1 << 26;

/// Samples per pixel along each axis for a `width × height` image: `supersample`,
/// lowered until the image fits [`MAX_SAMPLES`] (at least 1).
pub fn samples_per_axis(width: u32, height: u32, supersample: u32) -> u32 {
    let pixels = u64::from(width.max(1)) * u64::from(height.max(1));
    let mut s = supersample.max(1);
    while s > 1 && pixels * u64::from(s * s) > MAX_SAMPLES {
        s -= 1;
    }
    s
}

/// Renders `frame` as splats.
pub fn render(frame: &Frame, opts: &RenderOptions) -> Image {
    let cam = camera_for(frame, opts);
    let s = samples_per_axis(opts.width, opts.height, opts.supersample);
    let (w, h) = (opts.width.max(1) * s, opts.height.max(1) * s);
    let (eye, fwd, right, up) = cam.basis();
    let f = cam.focal(h);
    let bg = BACKGROUND.map(|c| c as f32 / 255.0);
    let mut colour = vec![bg; (w * h) as usize];
    let mut depth = vec![f32::INFINITY; (w * h) as usize];
    let mut ov_colour = colour.clone();
    let mut ov_depth = depth.clone();
    // Key light from the upper left of the viewer, fill from the camera.
    let key = (-0.45 * right + 0.8 * up - 0.5 * fwd).normalize();
    let fallback = fallback_radius(frame);
    for i in 0..frame.len() {
        let p = frame.pos[i];
        let r = disc_radius(frame, i, fallback) * opts.splat_scale;
        let q = p - eye;
        let z = q.dot(fwd);
        if z <= r || !p.is_finite() {
            continue;
        }
        let cx = 0.5 * w as f32 + f * q.dot(right) / z;
        let cy = 0.5 * h as f32 - f * q.dot(up) / z;
        let rp = f * r / (z - r) + 1.0;
        let (x0, x1) = (
            (cx - rp).floor().max(0.0),
            (cx + rp).ceil().min(w as f32 - 1.0),
        );
        let (y0, y1) = (
            (cy - rp).floor().max(0.0),
            (cy + rp).ceil().min(h as f32 - 1.0),
        );
        if x0 > x1 || y0 > y1 {
            continue;
        }
        let mut n = frame.normal[i].normalize_or_zero();
        if n == Vec3::ZERO {
            n = -q / z;
        }
        if n.dot(q) > 0.0 {
            n = -n;
        }
        let contact = frame.contact[i] != 0;
        let base = match (contact, opts.contact_levels) {
            (true, true) => level_colour(frame.contact[i]),
            (true, false) => CONTACT_COLOUR,
            (false, _) => object_colour(frame.object[i]),
        };
        let shaded = shade(contact, base, n, key, fwd);
        for py in y0 as u32..=y1 as u32 {
            for px in x0 as u32..=x1 as u32 {
                // Ray with unit forward component: t is the view depth.
                let d = fwd
                    + ((px as f32 + 0.5 - 0.5 * w as f32) / f) * right
                    + ((0.5 * h as f32 - py as f32 - 0.5) / f) * up;
                let denom = n.dot(d);
                if denom.abs() < 1e-4 {
                    continue; // disc seen edge-on
                }
                let t = n.dot(q) / denom;
                if (eye + t * d - p).length_squared() > r * r {
                    continue;
                }
                let k = (py * w + px) as usize;
                // Contact splats go to an overlay, its depth taken two disk radii nearer:
                // blended fully where it is at or in front of the objects' surface, dimmed
                // where an object hides it.
                let (depth, colour, t_depth) = if contact {
                    (&mut ov_depth, &mut ov_colour, t - 2.0 * r)
                } else {
                    (&mut depth, &mut colour, t)
                };
                if t > 0.0 && t_depth < depth[k] {
                    depth[k] = t_depth;
                    colour[k] = shaded;
                }
            }
        }
    }
    // Box-filter down to the output size.
    let (ow, oh) = (opts.width.max(1), opts.height.max(1));
    let rgb = downsample((ow, oh), s, w, (&colour, &depth), (&ov_colour, &ov_depth));
    Image {
        width: ow,
        height: oh,
        rgb,
    }
}

/// The colour of a splat of colour `base` with normal `n` (facing the eye): contact
/// surfels kept bright (an overlay), others under a key light `key` and a fill from the
/// camera (`fwd`: the view direction).
fn shade(contact: bool, base: [f32; 3], n: Vec3, key: Vec3, fwd: Vec3) -> [f32; 3] {
    let lambert = n.dot(key).max(0.0);
    let fill = n.dot(-fwd).max(0.0);
    let light = if contact {
        0.7 + 0.3 * lambert.max(fill) // the overlay stays bright
    } else {
        0.22 + 0.62 * lambert + 0.22 * fill
    };
    base.map(|c| (c * light).min(1.0))
}

/// RGB bytes of the `(ow, oh)` image from the supersampled buffers (`s` samples per
/// axis, `w` samples per row): each pixel the mean of its samples, the contact overlay
/// blended over the objects where it was drawn, with [`CONTACT_ALPHA`] where it is not
/// behind the objects' depth and [`CONTACT_HIDDEN_ALPHA`] where it is.
fn downsample(
    (ow, oh): (u32, u32),
    s: u32,
    w: u32,
    (colour, depth): (&[[f32; 3]], &[f32]),
    (ov_colour, ov_depth): (&[[f32; 3]], &[f32]),
) -> Vec<u8> {
    let mut rgb = Vec::with_capacity((3 * ow * oh) as usize);
    let norm = 1.0 / (s * s) as f32;
    for y in 0..oh {
        for x in 0..ow {
            let mut acc = [0.0f32; 3];
            for sy in 0..s {
                for sx in 0..s {
                    let k = ((y * s + sy) * w + x * s + sx) as usize;
                    let (c, o) = (colour[k], ov_colour[k]);
                    let a = match ov_depth[k] {
                        d if !d.is_finite() => 0.0,
                        d if d <= depth[k] => CONTACT_ALPHA,
                        _ => CONTACT_HIDDEN_ALPHA,
                    };
                    for k in 0..3 {
                        acc[k] += (1.0 - a) * c[k] + a * o[k];
                    }
                }
            }
            rgb.extend(acc.map(|a| (a * norm * 255.0).round().clamp(0.0, 255.0) as u8));
        }
    }
    rgb
}
