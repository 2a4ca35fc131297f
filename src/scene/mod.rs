//! Scenes: a TOML description of a simulation (docs/SCENES.md), and the built-in ones.

mod build;
mod builder;
pub mod camera;
mod check;
pub mod memory;
#[cfg(test)]
mod tests;
mod warnings;

use crate::io::arrays::exact_array;
pub use crate::world::Preset;

use check::f32_range;

pub use build::{CONTACT_BOUND_WARNING, MESH_EDGE, SELF_OVERLAP_SHARE, SELF_OVERLAP_WORK};
pub use check::{
    MAX_INSIDE_TEST_WORK, MAX_LATTICE_POINTS, MAX_PHYXELS, MAX_SURFELS, POSITION_RESOLUTION,
    fits_f32,
};
pub use warnings::{
    FLAT_WARNING, IMPACT_DEPTH_WARNING, MASS_WARNING, SURFACE_WARNING, WEIGHT_WARNING,
};

use crate::backends;
use crate::body::object::Object;
use crate::body::self_collision::SelfCollision;
use crate::body::shape::Shape;
use crate::material::Material;
use crate::points::phyxels::Phyxels;
use crate::points::surfels::Surfels;
use crate::scene::camera::Camera;
use crate::spatial::morton;
use crate::world::World;
use glam::{EulerRot, Quat, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Built-in scenes: (name, TOML text). `phyxel scenes --show NAME` prints the text.
pub const BUILTIN: &[(&str, &str)] = &[
    ("two-spheres", include_str!("scenes/two-spheres.toml")),
    ("falling-sphere", include_str!("scenes/falling-sphere.toml")),
    ("cantilever", include_str!("scenes/cantilever.toml")),
    (
        "sphere-on-plane",
        include_str!("scenes/sphere-on-plane.toml"),
    ),
    ("soft-on-plane", include_str!("scenes/soft-on-plane.toml")),
    ("pile", include_str!("scenes/pile.toml")),
    ("newtons-cradle", include_str!("scenes/newtons-cradle.toml")),
    ("incline", include_str!("scenes/incline.toml")),
    ("hertz", include_str!("scenes/hertz.toml")),
    ("scale", include_str!("scenes/scale.toml")),
    (
        "plastic-fracture",
        include_str!("scenes/plastic-fracture.toml"),
    ),
    ("self-contact", include_str!("scenes/self-contact.toml")),
    ("plastic-pile", include_str!("scenes/plastic-pile.toml")),
    ("pile-20", include_str!("scenes/pile-20.toml")),
];

/// The scene `phyxel run` uses without an argument.
pub const DEFAULT_SCENE: &str = "two-spheres";

/// Edge of the cells, in surfel spacings, whose Morton order a sampled object's surfels
/// are stored in ([`morton::order`]). Cells of 1, 4 and 16 spacings run the 1M `scale`
/// scene equally fast (docs/PERFORMANCE.md); 4 keeps a cell's patch of about 16 surfels
/// together.
pub const SURFEL_ORDER_CELL: f32 = 4.0;

/// A whole scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Scene name (reported as `scene` in the run summary).
    #[serde(default)]
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// Time step (s). Omitted: 90% of the largest stable step.
    pub dt: Option<f32>,
    /// Number of steps `phyxel run` takes.
    #[serde(default = "default_steps")]
    pub steps: u64,
    /// Gravitational acceleration (m/s²).
    #[serde(default = "default_gravity", deserialize_with = "exact_array")]
    pub gravity: [f32; 3],
    #[serde(default)]
    pub output: Output,
    /// Camera for rendered frames (`phyxel run --png`); omitted: fitted to the first frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<Camera>,
    /// The method's configuration ([`Preset`]).
    #[serde(default)]
    pub preset: Preset,
    /// Contact forces on the resampled contact surface (`World::resampled_forces`);
    /// omitted: the preset's choice (`paper`: yes, `default`: no).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resampled_forces: Option<bool>,
    /// Contact pairs handled in order, each against the surfaces the pairs before it
    /// left (`World::pairs_in_order`); omitted: the preset's choice (`paper`: yes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pairs_in_order: Option<bool>,
    /// Groups of bodies that have stayed still sleep until something moving touches
    /// them (`World::sleep`); omitted: yes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sleep: Option<bool>,
    pub objects: Vec<ObjectSpec>,
}

/// The influence radius of `preset = "paper"`, in phyxel spacings (Müller et al. 2004,
/// §4.3: `h_i = 3 r_i`).
pub const PAPER_INFLUENCE: f32 = 3.0;
/// The contact-force distribution support of `preset = "paper"`, in influence radii
/// (Keiser et al. 2004, §7: the phyxels within twice the influence radius).
pub const PAPER_DISTRIBUTION_SUPPORT: f32 = 2.0;

fn default_steps() -> u64 {
    1000
}

fn default_gravity() -> [f32; 3] {
    [0.0, -9.81, 0.0]
}

/// Frame output settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Output {
    /// Write a frame every this many steps (with `--out`).
    pub every: u64,
    /// Also write phyxel frames.
    pub phyxels: bool,
}

impl Default for Output {
    fn default() -> Self {
        Self {
            every: 10,
            phyxels: false,
        }
    }
}

/// One `[[objects]]` entry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    #[serde(default)]
    pub name: String,
    pub shape: Shape,
    /// Phyxel lattice spacing (m). May be omitted when `phyxels` gives a target count.
    #[serde(default)]
    pub spacing: f32,
    /// Surfel spacing (m). Omitted: half the phyxel spacing (or from `surfels`).
    pub surfel_spacing: Option<f32>,
    /// Target phyxel count: sets the spacing to `(volume / phyxels)^(1/3)`.
    pub phyxels: Option<u32>,
    /// Target surfel count: sets the surfel spacing to `(area / surfels)^(1/2)`.
    pub surfels: Option<u32>,
    /// Influence radius of each phyxel in units of its spacing `r_i` (omitted:
    /// [`crate::points::phyxels::SUPPORT_FACTOR`], 2; Müller et al. 2004 and
    /// `preset = "paper"`: 3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub influence: Option<f32>,
    /// Dynamics backend (omitted: `"mls"`, [`ObjectSpec::backend_name`]); refused on a
    /// static object (kept as written, so that even `"mls"` there is seen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub backend: Option<String>,
    /// A static object never moves (ground planes, fixed obstacles).
    #[serde(default, rename = "static")]
    pub is_static: bool,
    /// Centre position (m).
    #[serde(default, deserialize_with = "exact_array")]
    pub position: [f32; 3],
    /// Rotation as Euler angles in degrees, applied about x, then y, then z.
    #[serde(default, deserialize_with = "exact_array")]
    pub rotation: [f32; 3],
    /// Initial velocity (m/s).
    #[serde(default, deserialize_with = "exact_array")]
    pub velocity: [f32; 3],
    #[serde(default)]
    pub material: Material,
    /// Anchored phyxel regions: boxes in object-local coordinates (before rotation).
    #[serde(default)]
    pub fixed: Vec<Region>,
    /// Zones sampled finer (graded sampling, `[[objects.refine]]`; the nodal backends
    /// `mls` and `mls-implicit` only).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub refine: Vec<Refine>,
    /// Constant external force on the object (N), spread over its free phyxels in
    /// proportion to their mass (like gravity).
    #[serde(default, deserialize_with = "exact_array")]
    pub load: [f32; 3],
    /// Seconds over which `load` ramps up linearly from zero (0: applied at once).
    #[serde(default)]
    pub load_ramp: f32,
    /// Self-collision (paper §8): phyxels of this object that come closer than their
    /// spacing without being rest neighbours are pushed apart. Off by default: only
    /// bodies that fold onto themselves need it.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub self_collision: bool,
}

/// The backend of an object that names none.
pub const DEFAULT_BACKEND: &str = "mls";

/// An axis-aligned box in object-local coordinates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    #[serde(deserialize_with = "exact_array")]
    pub min: [f32; 3],
    #[serde(deserialize_with = "exact_array")]
    pub max: [f32; 3],
}

/// A zone of an object sampled finer (`[[objects.refine]]`): a box (`min`, `max`) or a
/// sphere (`centre`, `radius`) in object-local coordinates (before rotation), and the
/// phyxel `spacing` inside it, rounded down to the object's spacing over a power of 2
/// (at most 64 times finer). Around the zone the sampling grades back to the object's
/// spacing, neighbouring cells within a factor 2 (`body::shape::graded`); the surfels
/// are finer by the same factor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Refine {
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::io::arrays::exact_array_opt"
    )]
    pub min: Option<[f32; 3]>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::io::arrays::exact_array_opt"
    )]
    pub max: Option<[f32; 3]>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::io::arrays::exact_array_opt"
    )]
    pub centre: Option<[f32; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f32>,
    /// Instead of a box or sphere: the named object's bounding box at the start, grown
    /// by `distance` (m, default 0), as a box in this object's coordinates.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub near: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance: Option<f32>,
    /// Phyxel spacing inside the zone (m).
    pub spacing: f32,
}

impl Refine {
    /// A box zone, `min`..`max` (object coordinates, m), sampled at `spacing`.
    pub fn boxed(min: [f32; 3], max: [f32; 3], spacing: f32) -> Self {
        Refine {
            min: Some(min),
            max: Some(max),
            centre: None,
            radius: None,
            near: None,
            distance: None,
            spacing,
        }
    }

    /// A sphere zone of `radius` about `centre` (object coordinates, m), sampled at
    /// `spacing`.
    pub fn sphere(centre: [f32; 3], radius: f32, spacing: f32) -> Self {
        Refine {
            min: None,
            max: None,
            centre: Some(centre),
            radius: Some(radius),
            near: None,
            distance: None,
            spacing,
        }
    }

    /// The zone within `distance` (m) of object `name`'s bounding box at the start,
    /// sampled at `spacing`.
    pub fn near(name: &str, distance: f32, spacing: f32) -> Self {
        Refine {
            min: None,
            max: None,
            centre: None,
            radius: None,
            near: Some(name.to_string()),
            distance: Some(distance),
            spacing,
        }
    }

    /// The zone, once checked (`ObjectSpec::validate`): a box or a sphere (`None` for a
    /// `near` zone until the build places it).
    pub fn zone(&self) -> Option<crate::body::shape::graded::Zone> {
        use crate::body::shape::graded::Zone;
        if self.near.is_some() || self.distance.is_some() {
            return None;
        }
        match (self.min, self.max, self.centre, self.radius) {
            (Some(min), Some(max), None, None) => Some(Zone::Box {
                min: min.into(),
                max: max.into(),
            }),
            (None, None, Some(centre), Some(radius)) => Some(Zone::Sphere {
                centre: centre.into(),
                radius,
            }),
            _ => None,
        }
    }
}

/// Command-line overrides applied when a scene is built.
#[derive(Clone, Debug, Default)]
pub struct BuildOptions {
    /// Overrides the scene's `dt`.
    pub dt: Option<f32>,
    /// Overrides the backend of every non-static object.
    pub backend: Option<String>,
    /// Run even when dt exceeds the stable bound.
    pub allow_unstable: bool,
    /// Target surfel count of every non-static object (overrides its spacing).
    pub surfels: Option<u32>,
    /// Target phyxel count of every non-static object (overrides its spacing).
    pub phyxels: Option<u32>,
    /// Overrides the scene's `preset`.
    pub preset: Option<Preset>,
    /// The memory the scene may need (bytes, estimated before building: `scene::memory`);
    /// `None`: 80% of what the system reports available (no check where it does not say).
    pub max_memory: Option<u64>,
    /// Give every object its output mesh (`Object::mesh`, for mesh frames: `run
    /// --mesh`): its shape's triangles, bound to its phyxels.
    pub meshes: bool,
}

/// An error that names where in the input it comes from.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError(pub String);

impl std::fmt::Display for SceneError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SceneError {}

/// Longest line of a parse error shown (characters).
const ECHO_LIMIT: usize = 160;

/// `message` with control characters replaced and every line cut to [`ECHO_LIMIT`]
/// characters: the TOML parser quotes the offending line whole, and one line of a
/// generated or hostile file can be hundreds of kilobytes (a deeply nested array echoed
/// 200 KB).
/// A caret line below a cut line whose caret the cut hides says the column instead.
fn clip_lines(message: &str) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut cut = false;
    for l in message.lines() {
        // The parser quotes the line: a control character in it (an escape sequence)
        // must not reach the terminal raw. One replacement character for each keeps
        // the caret under the column.
        let shown: String = l
            .chars()
            .map(|c| {
                if c.is_control() && c != '\t' {
                    '\u{fffd}'
                } else {
                    c
                }
            })
            .collect();
        let l = shown.as_str();
        let n = l.chars().count();
        let caret = l.trim_start_matches([' ', '|']).starts_with('^');
        if cut && caret && n > ECHO_LIMIT {
            let column = l.find('^').unwrap_or(0);
            out.push(format!("(the error is at column {column} of that line)"));
        } else if n > ECHO_LIMIT {
            let head: String = l.chars().take(ECHO_LIMIT).collect();
            out.push(format!("{head}… ({n} characters)"));
        } else {
            out.push(l.to_string());
        }
        cut = n > ECHO_LIMIT;
    }
    out.join("\n")
}

impl Scene {
    /// Parses scene TOML; `origin` names the file in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Self, SceneError> {
        // Numbers are read as f32: one outside its range would otherwise turn into
        // infinity or 0 and be reported as such, not as written.
        if let Ok(value) = toml::from_str::<toml::Value>(text) {
            f32_range("", &value).map_err(|m| SceneError(format!("{origin}: {m}")))?;
        }
        let scene: Scene = toml::from_str(text)
            .map_err(|e| SceneError(format!("{origin}: {}", clip_lines(&e.to_string()))))?;
        scene.validate(origin)?;
        Ok(scene)
    }

    /// Reads and parses a scene file.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let origin = path.display().to_string();
        // (A missing file gets the read's own message below.)
        if path.exists() {
            crate::io::check_input_file(path, crate::io::SCENE_FILE_LIMIT)
                .map_err(|e| SceneError(format!("{origin}: scene file: {e}")))?;
        }
        let text = std::fs::read_to_string(path)
            .map_err(|e| SceneError(format!("{origin}: cannot read scene file: {e}")))?;
        let mut scene = Self::parse(&text, &origin)?;
        // Mesh shapes: paths are relative to the scene file.
        let base = path.parent().unwrap_or(Path::new(""));
        let mut meshes = false;
        for (k, o) in scene.objects.iter_mut().enumerate() {
            if matches!(o.shape, Shape::Mesh { .. }) {
                o.shape
                    .load_mesh(base)
                    .map_err(|m| SceneError(format!("{origin}: objects[{k}].shape: {m}")))?;
                meshes = true;
            }
        }
        if meshes {
            scene.validate(&origin)?; // the size checks, now that the meshes are known
        }
        if scene.name.is_empty() {
            scene.name = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
        }
        Ok(scene)
    }

    /// A built-in scene by name.
    pub fn builtin(name: &str) -> Option<Self> {
        BUILTIN.iter().find(|(n, _)| *n == name).map(|(n, text)| {
            Self::parse(text, &format!("built-in scene '{n}'")).expect("built-in scenes are valid")
        })
    }

    /// A built-in scene name, or else a path to a TOML file.
    pub fn resolve(arg: &str) -> Result<Self, SceneError> {
        if let Some(s) = Self::builtin(arg) {
            return Ok(s);
        }
        let path = Path::new(arg);
        if path.exists() || arg.ends_with(".toml") {
            return Self::load(path);
        }
        let names: Vec<&str> = BUILTIN.iter().map(|(n, _)| *n).collect();
        Err(SceneError(format!(
            "unknown scene '{arg}': not a built-in scene ({}) and no such file",
            names.join(", ")
        )))
    }
}

impl Scene {
    /// The scene as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a scene serialises")
    }
}
