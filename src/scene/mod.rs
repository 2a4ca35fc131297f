//! Scenes: a TOML description of a simulation (docs/SCENES.md), and the built-in ones.

pub mod camera;

use crate::backends;
use crate::body::material::Material;
use crate::body::object::Object;
use crate::body::phyxels::Phyxels;
use crate::body::self_collision::SelfCollision;
use crate::body::shape::Shape;
use crate::body::surfels::Surfels;
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
];

/// The scene `phyxel run` uses without an argument.
pub const DEFAULT_SCENE: &str = "two-spheres";

/// Edge of the cells, in surfel spacings, whose Morton order a sampled object's surfels
/// are stored in ([`morton::order`]). Cells of 1, 4 and 16 spacings ran the 1M `scale`
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
    pub objects: Vec<ObjectSpec>,
}

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

/// Reads an array of exactly `N` numbers: serde's arrays stop after `N` and ignore the
/// rest, so `velocity = [1, 0, 0, 5]` would run as `[1, 0, 0]` without a word.
pub(crate) fn exact_array<'de, D, const N: usize>(d: D) -> Result<[f32; N], D::Error>
where
    D: serde::Deserializer<'de>,
{
    let v = Vec::<f32>::deserialize(d)?;
    let len = v.len();
    v.try_into().map_err(|_| {
        serde::de::Error::invalid_length(len, &format!("an array of {N} numbers").as_str())
    })
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

impl Scene {
    /// Parses scene TOML; `origin` names the file in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Self, SceneError> {
        // Numbers are read as f32: one outside its range would otherwise turn into
        // infinity or 0 and be reported as such, not as written.
        if let Ok(value) = toml::from_str::<toml::Value>(text) {
            f32_range("", &value).map_err(|m| SceneError(format!("{origin}: {m}")))?;
        }
        let scene: Scene =
            toml::from_str(text).map_err(|e| SceneError(format!("{origin}: {e}")))?;
        scene.validate(origin)?;
        Ok(scene)
    }

    /// Reads and parses a scene file.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let origin = path.display().to_string();
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

    /// Checks every value; errors name the file, the field and the value.
    pub fn validate(&self, origin: &str) -> Result<(), SceneError> {
        let err = |field: &str, msg: String| SceneError(format!("{origin}: {field}: {msg}"));
        if let Some(dt) = self.dt
            && !(dt.is_finite() && dt > 0.0)
        {
            return Err(err("dt", format!("dt = {dt}: must be a finite number > 0")));
        }
        if self.gravity.iter().any(|g| !g.is_finite()) {
            return Err(err(
                "gravity",
                format!("gravity = {:?}: must be finite", self.gravity),
            ));
        }
        if self.output.every == 0 {
            return Err(err("output.every", "every = 0: must be >= 1".into()));
        }
        if let Some(c) = &self.camera {
            c.validate().map_err(|m| err("camera", m))?;
        }
        if self.objects.is_empty() {
            return Err(err("objects", "the scene has no [[objects]]".into()));
        }
        for (k, o) in self.objects.iter().enumerate() {
            let at = format!("objects[{k}]");
            // Messages, summaries and fragments name objects: two of one name would be
            // ambiguous in all three. An unnamed object is called `object{k}` when built,
            // which an explicit name may take.
            let named = |j: usize| match self.objects[j].name.as_str() {
                "" => format!("object{j}"),
                name => name.to_string(),
            };
            let name = named(k);
            if let Some(first) = (0..k).find(|&j| named(j) == name) {
                let message = match (o.name.is_empty(), self.objects[first].name.is_empty()) {
                    (false, false) => format!("name = \"{name}\": objects[{first}] has it too"),
                    (false, true) => format!(
                        "name = \"{name}\": the unnamed objects[{first}] is called so; \
                         choose another name or name objects[{first}]"
                    ),
                    _ => format!(
                        "unnamed, it would be called \"{name}\", as objects[{first}] is \
                         named; give it a name"
                    ),
                };
                return Err(err(&format!("{at}.name"), message));
            }
            o.shape
                .validate()
                .map_err(|m| err(&format!("{at}.shape"), m))?;
            o.material
                .validate()
                .and_then(|()| o.material.plastic_keys_used())
                .map_err(|m| err(&format!("{at}.material"), m))?;
            let size = o.shape.half_extents().max_element() * 2.0;
            for (name, n) in [("phyxels", o.phyxels), ("surfels", o.surfels)] {
                if n == Some(0) {
                    return Err(err(
                        &format!("{at}.{name}"),
                        format!("{name} = 0: must be >= 1"),
                    ));
                }
            }
            // Two ways to set one sampling: taking one silently would hide a mistake.
            let both = [
                (
                    o.phyxels.is_some() && o.spacing != 0.0,
                    "phyxels",
                    "spacing",
                ),
                (
                    o.surfels.is_some() && o.surfel_spacing.is_some(),
                    "surfels",
                    "surfel_spacing",
                ),
            ];
            if let Some((_, count, spacing)) = both.iter().find(|b| b.0) {
                return Err(err(
                    &format!("{at}.{count}"),
                    format!("both {count} and {spacing} are given: give one of them"),
                ));
            }
            for (name, n, limit) in [
                ("phyxels", o.phyxels, MAX_PHYXELS),
                ("surfels", o.surfels, MAX_SURFELS),
            ] {
                sample_count(name, n, limit).map_err(|m| err(&format!("{at}.{name}"), m))?;
            }
            if o.is_static {
                static_keys(o).map_err(|(key, m)| err(&format!("{at}.{key}"), m))?;
            }
            if o.phyxels.is_some() && o.spacing == 0.0 {
                // The spacing follows from the count once the shape is sampled.
            } else if o.spacing == 0.0 {
                return Err(err(
                    &format!("{at}.spacing"),
                    "spacing = 0 (or missing): give a phyxel spacing > 0 (m) or a `phyxels` \
                     count"
                        .into(),
                ));
            } else if !(o.spacing.is_finite() && o.spacing > 0.0) {
                return Err(err(
                    &format!("{at}.spacing"),
                    format!("spacing = {}: must be a finite number > 0", o.spacing),
                ));
            }
            if o.spacing > size {
                return Err(err(
                    &format!("{at}.spacing"),
                    format!("spacing = {}: larger than the shape ({size})", o.spacing),
                ));
            }
            if let Some(s) = o.surfel_spacing
                && !(s.is_finite() && s > 0.0)
            {
                return Err(err(
                    &format!("{at}.surfel_spacing"),
                    format!("surfel_spacing = {s}: must be a finite number > 0"),
                ));
            }
            if o.load_ramp != 0.0 && o.load == [0.0; 3] && !o.is_static {
                return Err(err(
                    &format!("{at}.load_ramp"),
                    format!("load_ramp = {}: has no effect without a load", o.load_ramp),
                ));
            }
            if !(o.load_ramp.is_finite() && o.load_ramp >= 0.0) {
                return Err(err(
                    &format!("{at}.load_ramp"),
                    format!("load_ramp = {}: must be a finite number >= 0", o.load_ramp),
                ));
            }
            let vecs = [
                ("position", o.position),
                ("rotation", o.rotation),
                ("velocity", o.velocity),
                ("load", o.load),
            ];
            for (name, v) in vecs {
                if v.iter().any(|c| !c.is_finite()) {
                    return Err(err(
                        &format!("{at}.{name}"),
                        format!("{name} = {v:?}: must be finite"),
                    ));
                }
            }
            // f32 coordinates must resolve the object's finest spacing where it stands:
            // far out they round distances to 0 (zero phyxel spacings) or motion away.
            // (The offset only: a spacing too fine for the shape's own size is the
            // sample-count limit's business.)
            let phyxel_spacing = if o.spacing > 0.0 { o.spacing } else { size };
            let fine = phyxel_spacing.min(o.surfel_spacing.unwrap_or(f32::INFINITY));
            let reach = o.position.iter().fold(0.0f32, |m, c| m.max(c.abs()));
            let resolution = reach * f32::EPSILON;
            if resolution > POSITION_RESOLUTION * fine {
                return Err(err(
                    &format!("{at}.position"),
                    format!(
                        "position = {:?}: too far from the origin for f32 coordinates: there \
                         they resolve {resolution:.2e} m, more than 1/{} of the finest \
                         spacing {fine} m; move the scene nearer the origin",
                        o.position,
                        (1.0 / POSITION_RESOLUTION).round()
                    ),
                ));
            }
            if let Some(b) = o.backend.as_deref().filter(|_| o.material.is_plastic())
                && !backends::PLASTIC.contains(&b)
            {
                return Err(err(
                    &format!("{at}.backend"),
                    format!(
                        "backend = \"{b}\" models no plastic flow, so the material's \
                         plastic_yield and plastic_creep would do nothing (plastic flow: {})",
                        backends::PLASTIC.join(", ")
                    ),
                ));
            }
            if !o.is_static && !backends::NAMES.contains(&o.backend_name()) {
                return Err(err(
                    &format!("{at}.backend"),
                    format!(
                        "backend = \"{}\": unknown (available: {})",
                        o.backend_name(),
                        backends::NAMES.join(", ")
                    ),
                ));
            }
            for (r, reg) in o.fixed.iter().enumerate() {
                if reg.min.iter().chain(&reg.max).any(|c| c.is_nan()) {
                    return Err(err(
                        &format!("{at}.fixed[{r}]"),
                        format!(
                            "min = {:?}, max = {:?}: must be numbers (not NaN)",
                            reg.min, reg.max
                        ),
                    ));
                }
                if (0..3).any(|c| reg.min[c] > reg.max[c]) {
                    return Err(err(
                        &format!("{at}.fixed[{r}]"),
                        format!(
                            "min = {:?}, max = {:?}: min must not exceed max",
                            reg.min, reg.max
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The scene as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).expect("a scene serialises")
    }

    /// Samples every object and assembles the world. The scene is checked first
    /// ([`Scene::validate`]): its fields are public, and a scene changed in code must
    /// get the same errors as one read from a file, not a panic or a NaN world.
    pub fn build(&self, opts: &BuildOptions) -> Result<World, SceneError> {
        let origin = if self.name.is_empty() {
            "scene"
        } else {
            &self.name
        };
        self.validate(origin)?;
        for (flag, name, n, limit) in [
            ("--surfels", "surfels", opts.surfels, MAX_SURFELS),
            ("--phyxel-count", "phyxels", opts.phyxels, MAX_PHYXELS),
        ] {
            if n == Some(0) {
                return Err(SceneError(format!(
                    "{origin}: {flag} 0: an object needs at least one sample"
                )));
            }
            sample_count(name, n, limit)
                .map_err(|m| SceneError(format!("{origin}: {flag}: {m}")))?;
        }
        if let Some(b) = opts.backend.as_deref()
            && !backends::NAMES.contains(&b)
        {
            return Err(SceneError(format!(
                "{origin}: backend override \"{b}\": unknown (available: {})",
                backends::NAMES.join(", ")
            )));
        }
        let mut objects = Vec::with_capacity(self.objects.len());
        let mut placed = Vec::with_capacity(self.objects.len());
        let mut warnings = Vec::new();
        // A per-object warning as the build reports it.
        let tagged = |k: usize, obj: &Object, w: String| {
            format!("{origin}: objects[{k}] '{}': {w}", obj.name)
        };
        let gravity = Vec3::from(self.gravity);
        let grounded = self.objects.iter().any(|o| o.is_static);
        for (k, spec) in self.objects.iter().enumerate() {
            let mut spec = spec.clone();
            // Loaded here once (a no-op if `Scene::load` did), for the overlap check too.
            spec.shape
                .load_mesh(Path::new(""))
                .map_err(|m| SceneError(format!("{origin}: objects[{k}].shape: {m}")))?;
            placed.push((spec.shape.clone(), spec.placement()));
            if !spec.is_static {
                spec.surfels = opts.surfels.or(spec.surfels);
                spec.phyxels = opts.phyxels.or(spec.phyxels);
            }
            let backend = match (&opts.backend, spec.is_static) {
                (_, true) => "static".to_string(),
                (Some(b), false) => b.clone(),
                (None, false) => spec.backend_name().to_string(),
            };
            let obj = spec
                .build(k as u32, &backend)
                .map_err(|m| SceneError(format!("{origin}: objects[{k}]: {m}")))?;
            // Only an override can get here with a plastic material on such a backend
            // (the scene's own `backend` is checked above): compared backends run it.
            let inelastic = (spec.material.is_plastic()
                && !spec.is_static
                && !backends::PLASTIC.contains(&backend.as_str()))
            .then(|| {
                format!(
                    "backend {backend} models no plastic flow: plastic_yield and \
                     plastic_creep are ignored, the body is elastic (plastic flow: {})",
                    backends::PLASTIC.join(", ")
                )
            });
            for w in [
                mass_warning(&spec, &obj),
                surface_warning(&spec, &obj),
                flat_warning(&obj),
                inelastic,
            ]
            .into_iter()
            .flatten()
            {
                warnings.push(tagged(k, &obj, w));
            }
            objects.push(obj);
        }
        // After every object is built: the weight check counts the bodies stacked above.
        // (None without gravity: nothing stacks, and `load_above` reads none.)
        let footprints: Vec<Footprint> = if gravity == Vec3::ZERO {
            Vec::new()
        } else {
            objects.iter().map(|o| footprint(o, gravity)).collect()
        };
        for (k, obj) in objects.iter().enumerate() {
            let supported = grounded || obj.phyxels.fixed.iter().any(|&f| f != 0);
            let load = load_above(&objects, &footprints, k, gravity);
            if let Some(w) = weight_warning(obj, gravity, supported, load) {
                warnings.push(tagged(k, obj, w));
            }
        }
        start_overlap(&objects, &placed).map_err(|m| SceneError(format!("{origin}: {m}")))?;
        warnings.extend(
            self.fast_approaches()
                .into_iter()
                .chain(self.deep_impacts(&objects))
                .map(|w| format!("{origin}: {w}")),
        );
        let mut world = World::new(objects, gravity, 0.0);
        let (stable, limiter_object) = world.stable_dt();
        let limiter = limiter_object.map(|o| o.name.clone()).unwrap_or_default();
        if stable.is_nan() || stable <= 0.0 {
            // Values each in range whose combination leaves f32's range: name them all.
            let what = limiter_object.map_or(String::new(), |o| {
                let m = &o.material;
                format!(
                    " (young = {:e} Pa, density = {:e} kg/m³, volume_stiffness = {:e} Pa, \
                     damping = {:e}, contact_stiffness = {:e}, phyxel spacing r_i = {:e} m)",
                    m.young,
                    m.density,
                    m.k_volume(),
                    m.damping,
                    m.contact_stiffness,
                    o.phyxel_spacing
                )
            });
            return Err(SceneError(format!(
                "{origin}: object '{limiter}' has no stable time step (bound {stable} s): its \
                 material and spacing{what} leave f32's range together; check them"
            )));
        }
        let dt = match opts.dt.or(self.dt) {
            Some(dt) => {
                if !(dt.is_finite() && dt > 0.0) {
                    return Err(SceneError(format!(
                        "{origin}: dt = {dt}: must be a finite number > 0"
                    )));
                }
                if dt > stable && !opts.allow_unstable {
                    // Full precision: rounded to a few digits, dt and the bound can print equal.
                    // The suggestion (the default dt) rounds to a value still below the bound.
                    let suggest = crate::world::DT_FRACTION * stable;
                    return Err(SceneError(format!(
                        "{origin}: dt = {dt} s exceeds the stable bound {stable} s of object '{limiter}' \
                         (explicit integration would blow up); use --dt {suggest:.3e} (90% of the bound, \
                         the default) or smaller, a coarser spacing or a softer material, or --allow-unstable"
                    )));
                }
                dt
            }
            None => (crate::world::DT_FRACTION * stable).min(crate::world::MAX_DEFAULT_DT),
        };
        world.dt = dt;
        world.keep_stable = !opts.allow_unstable;
        world.record.warnings = warnings;
        Ok(world)
    }
}

impl Scene {
    /// Pairs of objects whose start velocities close them faster than the slower P-wave
    /// speed of the two materials (along the line between their centres): penalty
    /// contact holds impacts up to about that speed (`two-spheres`, c = 11.6 m/s: 12
    /// m/s closing bounces, 14 m/s passes through with the default `contact_stiffness`),
    /// and a pass-through loses no energy, so the energy check cannot see it.
    /// Pairs whose start velocities close them so fast that the penalty spring needs
    /// more than [`IMPACT_DEPTH_WARNING`] of the thinner body's thickness scale `3V/A`
    /// to stop them (head-on along the line between their centres, as
    /// `fast_approaches`). Stopping depth of a body of curvature radius R (the smaller moving
    /// body's `3V/A`, its radius for a sphere) on the spring `k` per area
    /// ([`crate::world::contact_params`]): `½ μ v² = ⅔ π R k d³` (the contact disc's area
    /// `2π R d`), μ the pair's reduced mass (the moving body's mass against a static
    /// one). A 5 cm ball at 100 m/s needs 2.6 cm, and passed through a 1 cm static wall
    /// with every value finite and no other warning. Planes (no volume) count as thick.
    fn deep_impacts(&self, objects: &[Object]) -> Vec<String> {
        let thickness = |i: usize| thickness_scale(&self.objects[i].shape).unwrap_or(f64::INFINITY);
        let mut out = Vec::new();
        for (k, a) in objects.iter().enumerate() {
            for (l, b) in objects.iter().enumerate().skip(k + 1) {
                let closing = self.closing_speed(k, l) as f64;
                if closing <= 0.0 {
                    continue;
                }
                let mass = |o: &Object| (!o.is_static()).then(|| o.phyxels.total_mass());
                let mu = match (mass(a), mass(b)) {
                    (Some(ma), Some(mb)) => ma * mb / (ma + mb),
                    (Some(m), None) | (None, Some(m)) => m,
                    (None, None) => continue,
                };
                let radius = [(a, k), (b, l)]
                    .into_iter()
                    .filter(|(o, _)| !o.is_static())
                    .map(|(_, i)| thickness(i))
                    .fold(f64::INFINITY, f64::min);
                let thinnest = thickness(k).min(thickness(l));
                let spring = crate::world::contact_params(a, b, 1.0).stiffness as f64;
                let depth = (3.0 * mu * closing * closing
                    / (4.0 * std::f64::consts::PI * radius * spring))
                    .cbrt();
                if depth > IMPACT_DEPTH_WARNING * thinnest {
                    out.push(format!(
                        "{} and {} approach at {} m/s: the penalty contact needs \
                         about {depth:.2e} m of penetration to stop them, more than \
                         {IMPACT_DEPTH_WARNING} of the thinner body's thickness 3V/A = \
                         {thinnest:.2e} m: they may pass through each other; raise \
                         contact_stiffness, thicken the body or lower the speed \
                         (docs/SCENES.md, \"Limits\")",
                        self.label(k),
                        self.label(l),
                        speed_text(closing)
                    ));
                }
            }
        }
        out
    }

    /// How fast objects k and l close along the line between their positions at the
    /// start (m/s; negative when they fly apart, static objects at rest).
    fn closing_speed(&self, k: usize, l: usize) -> f32 {
        let (a, b) = (&self.objects[k], &self.objects[l]);
        let velocity = |o: &ObjectSpec| {
            if o.is_static {
                Vec3::ZERO
            } else {
                Vec3::from(o.velocity)
            }
        };
        let d = Vec3::from(b.position) - Vec3::from(a.position);
        -(velocity(b) - velocity(a)).dot(d.normalize_or_zero())
    }

    /// `objects[i] 'name'` (without the name if it has none), for messages.
    fn label(&self, i: usize) -> String {
        match self.objects[i].name.as_str() {
            "" => format!("objects[{i}]"),
            name => format!("objects[{i}] '{name}'"),
        }
    }

    fn fast_approaches(&self) -> Vec<String> {
        let mut out = Vec::new();
        for (k, a) in self.objects.iter().enumerate() {
            for (l, b) in self.objects.iter().enumerate().skip(k + 1) {
                let closing = self.closing_speed(k, l);
                let (slow, c) = [(a, k), (b, l)]
                    .into_iter()
                    .map(|(o, i)| (i, o.material.wave_speed()))
                    .fold((k, f32::INFINITY), |m, x| if x.1 < m.1 { x } else { m });
                if closing > c {
                    out.push(format!(
                        "{} and {} approach at {} m/s, faster than the P-wave speed \
                         {} m/s of {}: penalty contact may let them pass through each \
                         other; raise contact_stiffness or lower the speed (docs/SCENES.md, \
                         \"Limits\")",
                        self.label(k),
                        self.label(l),
                        speed_text(closing as f64),
                        speed_text(c as f64),
                        self.label(slow)
                    ));
                }
            }
        }
        out
    }
}

/// Stopping depth of an impact, as a fraction of the thinner body's thickness scale
/// `3V/A`, above which `Scene::build` warns (`Scene::deep_impacts`): penalty contact
/// pushes back only in proportion to depth, and a body pushed through more than its
/// thickness comes out on the other side. A 5 cm ball (E = 10 MPa) onto a 1 cm static
/// wall (3V/A = 1.45 cm), estimated depth against that thickness: 20 m/s 0.62 and
/// 30 m/s 0.81 bounced, 50 m/s 1.14 and 100 m/s 1.81 passed through (`mls`).
pub const IMPACT_DEPTH_WARNING: f64 = 0.75;

/// Relative difference between a moving object's sampled volume (phyxel count × lattice
/// cell) and its shape's analytic volume above which `Scene::build` warns
/// ([`World::warnings`]): mass is density × sampled volume, so a body a few phyxels
/// across gets too much or too little of it (a sphere sampled by 20 phyxels: +52%).
pub const MASS_WARNING: f64 = 0.25;

/// The warning for `obj` built from `spec` if its mass is off by more than
/// [`MASS_WARNING`] (moving objects of a shape with a volume only).
fn mass_warning(spec: &ObjectSpec, obj: &Object) -> Option<String> {
    let analytic = moving_volume(spec)?;
    let p = &obj.phyxels;
    let sampled: f64 = p.volume[..p.len()].iter().map(|&v| v as f64).sum();
    let off = sampled / analytic - 1.0;
    (off.abs() > MASS_WARNING).then(|| {
        format!(
            "its {} phyxels hold {sampled:.3e} m³ of the shape's {analytic:.3e} m³ ({:+.0}%), \
             and its mass (density × sampled volume) is off as much: refine the spacing \
             (about four phyxels across the thinnest part; docs/SCENES.md, \"Limits\")",
            p.len(),
            100.0 * off
        )
    })
}

/// The analytic volume (m³) of a moving object whose shape has one (not a plane, not an
/// empty mesh): what the sampling warnings measure against.
fn moving_volume(spec: &ObjectSpec) -> Option<f64> {
    let v = spec.shape.volume() as f64;
    (!spec.is_static && v > 0.0).then_some(v)
}

/// Largest mean surfel spacing `√(area / surfels)`, as a fraction of a moving body's
/// thickness scale `3 V / A` (its radius for a sphere), above which `Scene::build` warns
/// ([`World::warnings`]): the implicit surface cannot follow a body sampled so coarsely,
/// and contacts are missed. Measured on `two-spheres` (r = 0.1 m, ±1 m/s): with 20
/// surfels per sphere (0.79 of the radius) they pass through each other; with 25 (0.71)
/// they bounce but sink 39% of the radius in; with 40 (0.56) 14%, with 60 (0.46) 9%,
/// and at the default sampling a few percent (docs/SCENES.md, "Limits").
pub const SURFACE_WARNING: f64 = 0.5;

/// The warning for `obj` built from `spec` if its surfels are too sparse for its
/// size ([`SURFACE_WARNING`]; moving objects of a shape with a volume only).
fn surface_warning(spec: &ObjectSpec, obj: &Object) -> Option<String> {
    moving_volume(spec)?;
    let (thickness, area) = (thickness_scale(&spec.shape)?, spec.shape.area() as f64);
    let n = obj.surfels.len();
    let spacing = (area / n.max(1) as f64).sqrt();
    (spacing > SURFACE_WARNING * thickness).then(|| {
        format!(
            "its {n} surfels are {spacing:.3e} m apart on average, {:.2} of its thickness \
             scale 3V/A = {thickness:.3e} m (more than {SURFACE_WARNING}): contacts may be \
             missed or sink deep; refine the surfel spacing (docs/SCENES.md, \"Limits\")",
            spacing / thickness
        )
    })
}

/// Strain `ρ |g| H / E` under a body's own weight (H: its height along gravity) above
/// which the build warns that it may collapse. `sphere-on-plane` with the ball at
/// E = 3 kPa (0.67 by this H: the phyxels' height plus a spacing) held, squashed to a
/// third of its height; at 2 kPa (1.01) and below it sank through the plane on `mls`.
/// The `self-contact` ring, meant to buckle onto itself, is at 0.62; the other
/// built-in scenes stay below 0.1. Bodies stacked on it add their weight
/// (`load_above`: twice their mass counts as own weight).
pub const WEIGHT_WARNING: f32 = 0.8;

/// An object's phyxels seen along gravity: the box of their positions across it (two
/// axes) and their lowest point along it (the largest depth along `gravity`).
struct Footprint {
    lo: [f32; 2],
    hi: [f32; 2],
    lowest: f32,
}

/// The [`Footprint`] of `o` under a non-zero `gravity`.
fn footprint(o: &Object, gravity: Vec3) -> Footprint {
    let down = gravity.normalize();
    let (u, v) = down.any_orthonormal_pair();
    o.phyxels.pos.iter().fold(
        Footprint {
            lo: [f32::INFINITY; 2],
            hi: [f32::NEG_INFINITY; 2],
            lowest: f32::NEG_INFINITY,
        },
        |f, p| {
            let (a, b) = (p.dot(u), p.dot(v));
            Footprint {
                lo: [f.lo[0].min(a), f.lo[1].min(b)],
                hi: [f.hi[0].max(a), f.hi[1].max(b)],
                lowest: f.lowest.max(p.dot(down)),
            }
        },
    )
}

/// Mass (kg) that the other moving objects stack on `objects[k]` under `gravity`: those
/// whose lowest phyxel lies above its centre of mass and whose footprint (the box of
/// their phyxels across gravity) overlaps its own. They come to rest on it, or on a body
/// that rests on it, so their weight joins its own (0 without gravity). `footprints`
/// holds every object's [`footprint`].
fn load_above(objects: &[Object], footprints: &[Footprint], k: usize, gravity: Vec3) -> f32 {
    let obj = &objects[k];
    if obj.is_static() || gravity == Vec3::ZERO {
        return 0.0;
    }
    let own = &footprints[k];
    let c = obj.phyxels.centre_of_mass();
    let centre = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32).dot(gravity.normalize());
    objects
        .iter()
        .zip(footprints)
        .enumerate()
        .filter(|&(j, (o, _))| j != k && !o.is_static())
        .filter(|(_, (_, f))| {
            // `lowest` is the largest depth along gravity: above the centre means less.
            f.lowest < centre && (0..2).all(|a| f.lo[a] <= own.hi[a] && f.hi[a] >= own.lo[a])
        })
        .map(|(_, (o, _))| o.phyxels.total_mass() as f32)
        .sum()
}

/// The warning for a moving `obj` resting on something (a static object or its own
/// fixed phyxels) under `gravity` if its own weight and the `load` (kg) of the bodies
/// stacked on it ([`load_above`]) strain it past [`WEIGHT_WARNING`]:
/// `ρ |g| H / E · (1 + 2 load / m)`. Its own weight's stress grows from 0 at its top to
/// `ρ |g| H` at its base (mean strain half of that), a load's `|g| load / A` is the same
/// all through it (`A = V / H`, its mean cross-section): a load strains it as much as
/// twice its mass of own weight. A 10 cm cube (1 kg) under a 10 kg cube (docs/SCENES.md,
/// "Limits"): at E = 20 kPa (1.08) it was squeezed out through the plane, at 30 kPa
/// (0.72) it held but tipped, at 50 kPa (0.43) it held.
fn weight_warning(obj: &Object, gravity: Vec3, supported: bool, load: f32) -> Option<String> {
    let g = gravity.length();
    if obj.is_static() || !supported || g == 0.0 {
        return None;
    }
    let down = gravity / g;
    let (lo, hi) = obj
        .phyxels
        .pos
        .iter()
        .map(|p| p.dot(down))
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), h| {
            (a.min(h), b.max(h))
        });
    let height = hi - lo + obj.phyxel_spacing;
    let m = &obj.material;
    let factor = 1.0 + 2.0 * load / obj.phyxels.total_mass() as f32;
    let strain = m.density * g * height * factor / m.young;
    let what = if load > 0.0 {
        format!(
            "its own weight and the {load:.3e} kg of the bodies stacked on it strain it by \
             about ρ|g|H/E · (1 + 2 · {load:.3e} kg / m) = {strain:.2}"
        )
    } else {
        format!("its own weight strains it by about ρ|g|H/E = {strain:.2}")
    };
    (strain > WEIGHT_WARNING).then(|| {
        format!(
            "{what} (H = {height:.3e} m along gravity, E = {:e} Pa): too soft to keep its \
             shape; it may collapse and sink through what holds it (young >= {:.3e} Pa \
             keeps it below {WEIGHT_WARNING})",
            m.young,
            m.density * g * height * factor / WEIGHT_WARNING
        )
    })
}

/// Share of an object's phyxels with a flat neighbourhood
/// ([`crate::dynamics::Diagnostics::flat_phyxels`]) above which the build warns. The
/// built-in scenes have none; a plate one phyxel layer thick has all of them, and on
/// `mls` (no stiffness across the layer) a ball dropped on one crumpled it until it went
/// NaN, at any dt.
pub const FLAT_WARNING: f64 = 0.01;

/// The warning for `obj` if many of its phyxels have flat neighbourhoods
/// ([`FLAT_WARNING`]; backends that fit no moment matrix report none).
fn flat_warning(obj: &Object) -> Option<String> {
    let flat = obj
        .dynamics
        .diagnostics(&obj.phyxels, &obj.material)
        .flat_phyxels?;
    let n = obj.phyxels.len();
    (flat as f64 > FLAT_WARNING * n as f64).then(|| {
        format!(
            "{flat} of its {n} phyxels have neighbourhoods that do not span 3D (the body is \
             about one phyxel layer thick at this spacing): the {} backend has no stiffness \
             across them, so the body may crumple or blow up under load; refine the spacing \
             (at least two layers) or use sph",
            obj.dynamics.name()
        )
    })
}

/// The thickness scale `3V/A` of a shape (m): its radius for a sphere, half the side of a
/// cube, about 1.5 times a plate's thickness; `None` for shapes without a volume
/// (planes).
fn thickness_scale(shape: &Shape) -> Option<f64> {
    let (volume, area) = (shape.volume() as f64, shape.area() as f64);
    (volume > 0.0 && area > 0.0).then(|| 3.0 * volume / area)
}

/// Finest f32 resolution allowed at an object's position, as a fraction of its finest
/// spacing (`Scene::validate`): a millimetre-spaced object may stand up to about 10 m
/// from the origin, a 4 cm-spaced one about 300 m. Further out, f32 rounded phyxel
/// spacings to 0 and per-step motions away (a body at 50 km did not move at 1 m/s).
pub const POSITION_RESOLUTION: f32 = 1e-3;

/// Most phyxels one object may have: each costs about a kilobyte (neighbour lists, MLS
/// matrices, grids), so this is some 5 GB, and a spacing typed a few orders of magnitude
/// too small is refused before it exhausts memory.
pub const MAX_PHYXELS: usize = 5_000_000;
/// Most surfels one object may have (about 200 bytes each with binding and grids: some
/// 4 GB; the `scale` scene runs 1M per object).
pub const MAX_SURFELS: usize = 20_000_000;
/// Most lattice points the volume sampler may test for one object
/// ([`Shape::lattice_points`], about 2 ns each: some seconds). A thin torus 600 m
/// across at 0.2 mm spacing would have tested 10¹³ (hours) to keep a few thousand.
pub const MAX_LATTICE_POINTS: f64 = 2e9;

/// About how many phyxels the lattice of `spacing` puts into `shape`: the volume's
/// cells, the boundary layer's (area / spacing²), and one row along the longest extent,
/// which a needle thinner than the spacing still gets (its volume and area alone
/// counted 10⁵ phyxels of a 2 km needle that sampled 10⁷).
fn phyxel_estimate(shape: &Shape, spacing: f32) -> f64 {
    let (volume, area) = (shape.volume() as f64, shape.area() as f64);
    let s = spacing as f64;
    let longest = 2.0 * shape.half_extents().max_element() as f64;
    volume / s.powi(3) + area / s.powi(2) + longest / s
}

/// Whether a finite, non-zero `x` keeps its magnitude as an f32: within the normal f32
/// range, not rounded to infinity, to 0 or to a subnormal.
pub fn fits_f32(x: f64) -> bool {
    (f32::MIN_POSITIVE as f64..=f32::MAX as f64).contains(&x.abs())
}

/// A speed (m/s) for messages: three decimals, in scientific notation from 10⁴ on (a
/// speed of 1e30 printed 31 digits).
fn speed_text(v: f64) -> String {
    if v.abs() < 1e4 {
        format!("{v:.3}")
    } else {
        format!("{v:.3e}")
    }
}

/// Every float in `value` (at `path`) within the range of normal f32 numbers (or 0,
/// or not finite, which the field checks report); `Err` names the key and the value.
fn f32_range(path: &str, value: &toml::Value) -> Result<(), String> {
    match value {
        toml::Value::Float(x) => {
            if x.is_finite() && *x != 0.0 && !fits_f32(*x) {
                return Err(format!(
                    "{path}: {x:e}: outside the range of the f32 numbers the engine computes \
                     with (magnitudes from {:e} to {:e}, or 0)",
                    f32::MIN_POSITIVE,
                    f32::MAX
                ));
            }
            Ok(())
        }
        toml::Value::Table(t) => t.iter().try_for_each(|(k, v)| {
            let at = if path.is_empty() {
                k.clone()
            } else {
                format!("{path}.{k}")
            };
            f32_range(&at, v)
        }),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .try_for_each(|(i, v)| f32_range(&format!("{path}[{i}]"), v)),
        _ => Ok(()),
    }
}

/// Refuses objects that start inside one another: a phyxel of one more than a phyxel
/// spacing (the coarser of the two objects') inside another's shape (`placed`: each
/// object's shape and placement). Contact handling pushes apart surfaces that overlap by
/// about a spacing (the built-in `pile` starts with 2 mm); interpenetrating bodies it
/// cannot untangle (deep surfels project onto the wrong side: pairs stay stuck or pass
/// through). A plane counts below its patch only (its `size`, widened by that spacing):
/// its contact acts where its surfels are, and a body beside the patch falls past it (a
/// ball beside a 0.6 m ground patch, level with it, was refused as 9 cm inside it).
fn start_overlap(objects: &[Object], placed: &[(Shape, (Quat, Vec3))]) -> Result<(), String> {
    for (i, a) in objects.iter().enumerate() {
        for (j, (shape, (rot, centre))) in placed.iter().enumerate() {
            if i == j {
                continue;
            }
            let (inv, reach) = (rot.inverse(), shape.half_extents().length());
            let plane = match shape {
                Shape::Plane { size } => Some(*size),
                _ => None,
            };
            let slack = a.phyxel_spacing.max(objects[j].phyxel_spacing);
            let (mut inside, mut deepest) = (0usize, 0.0f32);
            for p in a.phyxels.pos.iter() {
                let local = inv * (p - *centre);
                // Beyond the bounding sphere nothing is inside; a plane's sdf is the
                // infinite plane's, so it is bounded by its patch (any depth below it).
                let outside = match plane {
                    Some([x, z]) => {
                        local.x.abs() > 0.5 * x + slack || local.z.abs() > 0.5 * z + slack
                    }
                    None => local.length() > reach,
                };
                if outside {
                    continue;
                }
                let d = shape.sdf(local);
                if d < -slack {
                    inside += 1;
                    deepest = deepest.max(-d);
                }
            }
            if inside > 0 {
                let b = &objects[j];
                return Err(format!(
                    "objects[{i}] ('{}') starts inside objects[{j}] ('{}'): {inside} of its \
                     phyxels lie more than a phyxel spacing r_i (their mean neighbour distance, {slack} m) within it, up to {deepest:.3e} m \
                     deep; place them apart (contact resolves touching surfaces, not bodies \
                     inside one another)",
                    a.name, b.name
                ));
            }
        }
    }
    Ok(())
}

/// Refuses a target count `name = n` above `limit`.
fn sample_count(name: &str, n: Option<u32>, limit: usize) -> Result<(), String> {
    match n {
        Some(n) if n as usize > limit => Err(format!(
            "{name} = {n}: more than the limit of {limit} per object"
        )),
        _ => Ok(()),
    }
}

/// A static object never moves: the keys that only act on moving objects are refused,
/// `Err((key, message))`, rather than ignored.
fn static_keys(o: &ObjectSpec) -> Result<(), (&'static str, String)> {
    let idle = "has no effect on a static object";
    if let Some(b) = &o.backend {
        return Err(("backend", format!("backend = \"{b}\": {idle}")));
    }
    for (key, v) in [("velocity", o.velocity), ("load", o.load)] {
        if v != [0.0; 3] {
            return Err((key, format!("{key} = {v:?}: {idle}")));
        }
    }
    if o.load_ramp != 0.0 {
        return Err(("load_ramp", format!("load_ramp = {}: {idle}", o.load_ramp)));
    }
    if o.self_collision {
        return Err(("self_collision", format!("self_collision = true: {idle}")));
    }
    if !o.fixed.is_empty() {
        return Err(("fixed", format!("{} fixed box(es): {idle}", o.fixed.len())));
    }
    // A static body never deforms: it can neither flow nor break.
    if o.material.fracture {
        return Err(("material", format!("fracture = true: {idle}")));
    }
    if o.material.plastic_yield.is_finite() {
        return Err((
            "material",
            format!("plastic_yield = {}: {idle}", o.material.plastic_yield),
        ));
    }
    Ok(())
}

/// The lattice spacing whose phyxel count is closest to `target`: starts from
/// `(volume/target)^(1/3)` (widened for thin shapes) and corrects a few times by the
/// cube root of the count ratio, since a small lattice's count jumps with the rounding
/// at the boundary. Never samples a lattice past the limits (it then returns the best
/// spacing so far, which `ObjectSpec::spacings` and the build check).
fn lattice_spacing_for(shape: &Shape, target: u32) -> f32 {
    let target = target as f32;
    let mut s = (shape.volume() / target).cbrt();
    // A shape thinner than that spacing (a needle, a thin ring) gets far more phyxels
    // than its volume says: widen the first guess until the estimate is within a factor
    // the boundary layer of a compact body stays under (a sphere of 20 phyxels: 3), so
    // the search never samples a lattice of billions.
    for _ in 0..64 {
        if !(s.is_finite() && s > 0.0) || phyxel_estimate(shape, s) <= 8.0 * target as f64 {
            break;
        }
        s *= 1.25;
    }
    let mut best = (f32::INFINITY, s);
    for _ in 0..8 {
        let affordable = phyxel_estimate(shape, s) <= 2.0 * MAX_PHYXELS as f64
            && shape.lattice_points(s) <= MAX_LATTICE_POINTS;
        if !(s.is_finite() && s > 0.0 && affordable) {
            break;
        }
        let n = shape.sample_volume(s).positions.len() as f32;
        let err = (n / target - 1.0).abs();
        if err < best.0 {
            best = (err, s);
        }
        if err < 0.01 {
            break;
        }
        s *= (n / target).cbrt();
    }
    best.1
}

impl ObjectSpec {
    /// The rigid placement: local → world.
    pub fn placement(&self) -> (Quat, Vec3) {
        let r = self.rotation.map(f32::to_radians);
        (
            Quat::from_euler(EulerRot::XYZ, r[0], r[1], r[2]),
            Vec3::from(self.position),
        )
    }

    /// Phyxel and surfel spacing (m): given, or from the target counts `phyxels` and
    /// `surfels` and the shape's volume and area.
    pub fn spacings(&self, shape: &Shape) -> Result<(f32, f32), String> {
        let spacing = match self.phyxels {
            Some(n) => lattice_spacing_for(shape, n),
            None => self.spacing,
        };
        let surfel = match (self.surfels, self.surfel_spacing) {
            (Some(n), _) => (shape.area() / n as f32).sqrt(),
            (None, Some(s)) => s,
            (None, None) => 0.5 * spacing,
        };
        if let Some(n) = self
            .phyxels
            .filter(|_| !(spacing.is_finite() && spacing > 0.0))
        {
            return Err(format!(
                "phyxels = {n}: the shape has no volume to divide (give `spacing` instead)"
            ));
        }
        if let Some(n) = self
            .surfels
            .filter(|_| !(surfel.is_finite() && surfel > 0.0))
        {
            return Err(format!(
                "surfels = {n}: the shape has no area to divide (give `surfel_spacing` instead)"
            ));
        }
        // Counts a given spacing leads to (the lattice's boundary layer included), so that
        // a spacing orders of magnitude too small is refused before sampling exhausts
        // memory. (Target counts are checked against the limits as they are.)
        let t = surfel as f64;
        let estimates = [
            (
                self.phyxels.is_none(),
                "spacing",
                spacing,
                phyxel_estimate(shape, spacing),
                MAX_PHYXELS,
                "phyxels",
            ),
            (
                self.surfels.is_none(),
                "surfel_spacing",
                surfel,
                shape.area() as f64 / t.powi(2),
                MAX_SURFELS,
                "surfels",
            ),
        ];
        for (given, key, value, n, limit, what) in estimates {
            if given && n > limit as f64 {
                let key = match key {
                    "surfel_spacing" if self.surfel_spacing.is_none() => "spacing / 2",
                    k => k,
                };
                return Err(format!(
                    "{key} = {value}: gives about {n:.2e} {what}, more than the limit of \
                     {limit} per object (a coarser spacing, or a count: `{what} = N`)"
                ));
            }
        }
        let scan = shape.lattice_points(spacing);
        if scan > MAX_LATTICE_POINTS {
            let key = self.spacing_key(spacing);
            return Err(format!(
                "{key}: the shape's bounding box holds {scan:.2e} lattice points to test, more \
                 than the limit of {MAX_LATTICE_POINTS:e} (the shape is thin for its extent): \
                 a coarser spacing"
            ));
        }
        Ok((spacing, surfel))
    }

    /// What set the phyxel spacing, for errors: the count asked for, or the spacing.
    fn spacing_key(&self, spacing: f32) -> String {
        match self.phyxels {
            Some(n) => format!("phyxels = {n} (spacing {spacing} m)"),
            None => format!("spacing = {spacing}"),
        }
    }

    /// The backend this object asks for: `backend`, else [`DEFAULT_BACKEND`].
    pub fn backend_name(&self) -> &str {
        self.backend.as_deref().unwrap_or(DEFAULT_BACKEND)
    }

    /// Samples the shape and creates the object with backend `backend`.
    pub fn build(&self, id: u32, backend: &str) -> Result<Object, String> {
        let (rot, pos) = self.placement();
        // A mesh not loaded by `Scene::load`: its path is relative to the working directory.
        let mut shape = self.shape.clone();
        shape.load_mesh(Path::new(""))?;
        let (spacing, surfel_spacing) = self.spacings(&shape)?;
        let vol = shape.sample_volume(spacing);
        // The estimates bound the sampling's cost; the count itself is known only now.
        if vol.positions.len() > MAX_PHYXELS {
            let key = self.spacing_key(spacing);
            return Err(format!(
                "{key}: gives {} phyxels, more than the limit of {MAX_PHYXELS} per object \
                 (a coarser spacing, or a smaller count: `phyxels = N`)",
                vol.positions.len()
            ));
        }
        // Each phyxel's mass is its lattice cell's volume times the density: both in range
        // can still overflow or underflow f32 together.
        let mass = vol.cell_volume * self.material.density;
        if !(mass.is_finite() && mass > 0.0) {
            return Err(format!(
                "material.density = {:e} kg/m³ at spacing = {spacing} m gives each phyxel a \
                 mass of {mass:e} kg ({:e} m³ × density), outside f32's range: change the \
                 density or the spacing",
                self.material.density, vol.cell_volume
            ));
        }
        let surf = shape.sample_surface(surfel_spacing);
        let points: Vec<Vec3> = vol.positions.iter().map(|&p| rot * p + pos).collect();
        let mut phyxels = Phyxels::at_rest(&points, vol.cell_volume, self.material.density);
        let v = Vec3::from(self.velocity);
        let mut anchored = vec![0usize; self.fixed.len()];
        for (i, local) in vol.positions.iter().enumerate() {
            let inside = |r: &Region| (0..3).all(|c| local[c] >= r.min[c] && local[c] <= r.max[c]);
            for (count, r) in anchored.iter_mut().zip(&self.fixed) {
                *count += inside(r) as usize;
            }
            if self.fixed.iter().any(inside) {
                phyxels.fixed[i] = 1;
            } else if !self.is_static {
                phyxels.vel.set(i, v);
            }
        }
        // A box that anchors nothing leaves the body free: a mistake, not a setting.
        if let Some(r) = anchored.iter().position(|&n| n == 0) {
            let b = &self.fixed[r];
            return Err(format!(
                "fixed[{r}]: the box min = {:?}, max = {:?} holds no phyxel at spacing {spacing} \
                 (object-local coordinates, before rotation): widen it or refine the spacing",
                b.min, b.max
            ));
        }
        // A body anchored whole never moves: its velocity and load would be ignored.
        if phyxels.fixed[..phyxels.len()].iter().all(|&f| f != 0) {
            for (key, v) in [("velocity", self.velocity), ("load", self.load)] {
                if v != [0.0; 3] {
                    return Err(format!(
                        "{key} = {v:?}: has no effect: the `fixed` boxes anchor every phyxel \
                         of the body (for a body that never moves, use `static = true`)"
                    ));
                }
            }
        }
        let s_pos: Vec<Vec3> = surf.positions.iter().map(|&p| rot * p + pos).collect();
        let s_nrm: Vec<Vec3> = surf.normals.iter().map(|&n| rot * n).collect();
        // Stored in Morton order of cells a few surfels wide: neighbours sit together in
        // memory, whatever order the sampler emitted them in.
        let order = morton::order(&s_pos, SURFEL_ORDER_CELL * surfel_spacing);
        let mut surfels = Surfels::at_rest(&s_pos, &s_nrm, &surf.radii).gather(&order);
        if !self.is_static {
            for s in 0..surfels.len() {
                surfels.vel.set(s, v);
            }
        }
        let dynamics = backends::create(backend, &phyxels, &self.material)?;
        let name = if self.name.is_empty() {
            format!("object{id}")
        } else {
            self.name.clone()
        };
        let mut object = Object::new(id, name, surfels, phyxels, self.material.clone(), dynamics);
        object.load = Vec3::from(self.load);
        object.load_ramp = self.load_ramp;
        if self.self_collision && !self.is_static {
            object.self_collision = Some(SelfCollision::new(&object.phyxels));
        }
        Ok(object)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Speeds in the build's warnings: three decimals up to 10⁴ m/s, then scientific
    /// notation (1e30 m/s printed 31 digits).
    #[test]
    fn speeds_in_messages_stay_short() {
        assert_eq!(speed_text(11.6024), "11.602");
        assert_eq!(speed_text(9999.0), "9999.000");
        assert_eq!(speed_text(1.0e30), "1.000e30");
        assert_eq!(speed_text(-2.5e5), "-2.500e5");
    }

    /// The built-in scenes are sampled finely enough for their masses: none warns.
    #[test]
    fn builtin_scenes_build_without_warnings() {
        for &(name, _) in BUILTIN {
            let world = Scene::builtin(name)
                .expect("builtin")
                .build(&BuildOptions::default())
                .expect("builds");
            assert!(
                world.record.warnings.is_empty(),
                "{name}: {:?}",
                world.record.warnings
            );
        }
    }

    /// A 5 cm ball (E = 10 MPa, 0.55 kg) thrown at a static wall 1 cm thick
    /// (3V/A = 1.45 cm): the penalty spring `k = κE*/h` needs a depth
    /// `d = (3 m v²/(4π R k))^(1/3)` to stop it, 2.6 cm at 100 m/s (it passed through),
    /// 0.9 cm at 20 m/s (it bounced): the build warns at 100 m/s, naming both objects
    /// and the depth, and not at 20 m/s, nor when the ball flies away from the wall.
    #[test]
    fn an_impact_deeper_than_the_wall_warns() {
        let scene = |v: f32| {
            Scene::parse(
                &format!(
                    "name = \"wall\"\ngravity = [0.0, 0.0, 0.0]\n\
                     [[objects]]\nname = \"wall\"\nstatic = true\n\
                     shape = {{ type = \"box\", size = [0.6, 0.01, 0.6] }}\nspacing = 0.01\n\
                     surfel_spacing = 0.005\nmaterial = {{ young = 1.0e7 }}\n\
                     [[objects]]\nname = \"ball\"\nshape = {{ type = \"sphere\", radius = 0.05 }}\n\
                     spacing = 0.0125\nsurfel_spacing = 0.004\nposition = [0.0, 0.06, 0.0]\n\
                     velocity = [0.0, {v}, 0.0]\nmaterial = {{ young = 1.0e7 }}\n"
                ),
                "wall",
            )
            .expect("parses")
            .build(&BuildOptions::default())
            .expect("builds")
            .record
            .warnings
        };
        let fast = scene(-100.0);
        let [w] = fast.as_slice() else {
            panic!("{fast:?}")
        };
        assert!(
            w.contains("objects[0] 'wall' and objects[1] 'ball'") && w.contains("2.63e-2 m"),
            "{w}"
        );
        assert!(scene(-20.0).is_empty(), "{:?}", scene(-20.0));
        assert!(scene(100.0).is_empty(), "{:?}", scene(100.0));
    }

    /// `sphere-on-plane` with the ball at E = 1 kPa: its weight strains it by
    /// ρ|g|H/E = 1000 · 9.81 · 0.206 / 1000 = 2.02 (H: the phyxels' height plus a
    /// spacing), so the build warns, naming the ball; at the scene's 100 kPa (0.02), in
    /// zero gravity, or with nothing to rest on (the plane removed) it does not.
    #[test]
    fn a_body_too_soft_for_its_weight_warns() {
        let scene = Scene::builtin("sphere-on-plane").expect("builtin");
        let mut soft = scene.clone();
        soft.objects[1].material.young = 1e3;
        let warnings = |s: &Scene| {
            s.build(&BuildOptions::default())
                .expect("builds")
                .record
                .warnings
        };
        let w = warnings(&soft);
        let [w] = w.as_slice() else { panic!("{w:?}") };
        assert!(
            w.contains("objects[1] 'ball'") && w.contains("= 2.02"),
            "{w}"
        );
        assert!(warnings(&scene).is_empty());
        let mut weightless = soft.clone();
        weightless.gravity = [0.0; 3];
        assert!(warnings(&weightless).is_empty());
        let mut falling = soft.clone();
        falling.objects.remove(0);
        assert!(warnings(&falling).is_empty());
    }

    /// A plate one phyxel layer thick (0.3 × 0.005 × 0.3 m at 5 mm spacing: 3600 phyxels,
    /// every MLS moment matrix rank 2) warns on `mls`, naming the object and the count;
    /// two layers (10 mm thick) do not, and neither does `sph` (no moment matrix).
    #[test]
    fn a_plate_one_layer_thick_warns_on_mls() {
        let plate = |thick: f32| {
            Scene::parse(
                &format!(
                    "name = \"plate\"\n[[objects]]\nname = \"plate\"\n\
                     shape = {{ type = \"box\", size = [0.3, {thick}, 0.3] }}\nspacing = 0.005\n"
                ),
                "plate",
            )
            .expect("parses")
        };
        let warnings = |scene: &Scene, backend: &str| {
            let opts = BuildOptions {
                backend: Some(backend.into()),
                ..BuildOptions::default()
            };
            scene.build(&opts).expect("builds").record.warnings
        };
        let thin = warnings(&plate(0.005), "mls");
        let [w] = thin.as_slice() else {
            panic!("{thin:?}")
        };
        assert!(
            w.contains("objects[0] 'plate'") && w.contains("3600 of its 3600 phyxels"),
            "{w}"
        );
        assert!(warnings(&plate(0.01), "mls").is_empty());
        assert!(warnings(&plate(0.005), "sph").is_empty());
    }

    /// A plastic material on a backend without plastic flow would silently run elastic:
    /// named in the scene it is refused (naming the object's `backend`), given by
    /// `--backend` (as `compare` does) it warns once per plastic object; on `mls` it
    /// neither warns nor fails.
    #[test]
    fn plastic_flow_on_an_elastic_backend_is_refused_or_warned() {
        let scene = Scene::builtin("plastic-pile").expect("builtin");
        let plastic = scene
            .objects
            .iter()
            .filter(|o| o.material.is_plastic())
            .count();
        assert!(plastic > 0);
        for backend in ["sph", "lj"] {
            let opts = BuildOptions {
                backend: Some(backend.into()),
                ..BuildOptions::default()
            };
            let world = scene.build(&opts).expect("builds");
            let warned = world
                .record
                .warnings
                .iter()
                .filter(|w| w.contains("no plastic flow"));
            assert_eq!(
                warned.count(),
                plastic,
                "{backend}: {:?}",
                world.record.warnings
            );
            let mut named = scene.clone();
            let k = named
                .objects
                .iter()
                .position(|o| o.material.is_plastic())
                .unwrap();
            named.objects[k].backend = Some(backend.into());
            let e = named
                .build(&BuildOptions::default())
                .expect_err("refused")
                .0;
            assert!(
                e.contains(&format!("objects[{k}].backend")) && e.contains("no plastic flow"),
                "{e}"
            );
        }
        let mut on_mls = scene.clone();
        on_mls.objects.iter_mut().for_each(|o| {
            if !o.is_static {
                o.backend = Some("mls".into())
            }
        });
        let world = on_mls.build(&BuildOptions::default()).expect("builds");
        assert!(
            world.record.warnings.is_empty(),
            "{:?}",
            world.record.warnings
        );
    }

    /// A sphere (r = 0.1 m) sampled by 20 phyxels holds 52% more lattice volume than
    /// the sphere's 4.19e-3 m³, so its mass is that much too large: the build warns,
    /// naming the object and the sampled and analytic volumes (m³). At the default
    /// spacing (280 phyxels, +4.4%) it does not.
    #[test]
    fn a_coarse_body_warns_of_its_mass() {
        let mut scene = Scene::builtin("falling-sphere").expect("builtin");
        let fine = scene.build(&BuildOptions::default()).expect("builds");
        assert!(
            fine.record.warnings.is_empty(),
            "{:?}",
            fine.record.warnings
        );
        scene.objects[0].spacing = 0.0;
        scene.objects[0].phyxels = Some(20);
        let world = scene.build(&BuildOptions::default()).expect("builds");
        let p = &world.objects[0].phyxels;
        let sampled: f32 = p.volume[..p.len()].iter().sum();
        let analytic = 4.0 / 3.0 * std::f32::consts::PI * 0.1f32.powi(3);
        assert!(
            sampled / analytic - 1.0 > MASS_WARNING as f32,
            "{sampled} m³"
        );
        let [w] = world.record.warnings.as_slice() else {
            panic!("{:?}", world.record.warnings)
        };
        assert!(
            w.contains("objects[0] 'sphere'") && w.contains("4.189e-3 m³"),
            "{w}"
        );
    }

    /// `two-spheres` (P-wave speed √((λ + 2μ)/ρ) = 11.60 m/s for E = 100 kPa, ν = 0.3,
    /// ρ = 1000 kg/m³) at ±7 m/s closes at 14 m/s: the build warns once, naming both
    /// spheres and the speeds (m/s); at ±5 m/s (10 m/s closing) and when the spheres fly
    /// apart at ±7 m/s it does not.
    #[test]
    fn a_faster_than_sound_approach_warns() {
        let warnings = |v: f32| {
            let mut scene = Scene::builtin("two-spheres").expect("builtin");
            scene.objects[0].velocity = [v, 0.0, 0.0];
            scene.objects[1].velocity = [-v, 0.0, 0.0];
            scene
                .build(&BuildOptions::default())
                .expect("builds")
                .record
                .warnings
        };
        let c = Material::default().wave_speed();
        assert!((c - 11.60).abs() < 0.01, "P-wave speed {c} m/s");
        let fast = warnings(7.0);
        let [w] = fast.as_slice() else {
            panic!("{fast:?}")
        };
        assert!(
            w.contains("'left'") && w.contains("'right'") && w.contains("14.000 m/s"),
            "{w}"
        );
        assert!(warnings(5.0).is_empty(), "{:?}", warnings(5.0));
        assert!(warnings(-7.0).is_empty(), "{:?}", warnings(-7.0));
    }

    /// Two spheres (r = 0.1 m) of 20 surfels each (mean spacing √(4π r² / 20) = 0.079 m,
    /// 0.79 of the thickness scale 3V/A = r) pass through each other at ±1 m/s: the
    /// build warns, naming the object, the spacing and the scale (m). With 60 surfels
    /// (0.46 r, which bounces) and at the default sampling it does not.
    #[test]
    fn sparse_surfels_warn() {
        let scene = Scene::builtin("two-spheres").expect("builtin");
        let warnings = |surfels: Option<u32>| {
            let opts = BuildOptions {
                surfels,
                ..Default::default()
            };
            scene.build(&opts).expect("builds").record.warnings
        };
        let sparse = warnings(Some(20));
        assert_eq!(sparse.len(), 2, "{sparse:?}");
        assert!(
            sparse[0].contains("objects[0] 'left'")
                && sparse[0].contains("its 20 surfels")
                && sparse[0].contains("7.927e-2 m apart")
                && sparse[0].contains("3V/A = 1.000e-1 m"),
            "{}",
            sparse[0]
        );
        assert!(warnings(Some(60)).is_empty(), "{:?}", warnings(Some(60)));
        assert!(warnings(None).is_empty(), "{:?}", warnings(None));
    }

    /// A three-vector key given four numbers (or a plane's size three) is refused with
    /// the line and the count, not cut to its first numbers: serde's fixed arrays read
    /// the first N and ignored the rest, so `velocity = [0, 0, 0, 5]` ran at rest.
    #[test]
    fn arrays_of_the_wrong_length_are_refused() {
        let object = |line: &str| {
            format!(
                "name = \"x\"\n[[objects]]\nshape = {{ type = \"sphere\", radius = 0.1 }}\nspacing = 0.02\n{line}\n"
            )
        };
        for line in [
            "velocity = [0.0, 0.0, 0.0, 5.0]",
            "position = [0.0, 0.0, 0.0, 1e9]",
            "rotation = [0.0, 0.0]",
            "load = [1.0, 0.0, 0.0, 0.0]",
        ] {
            let e = Scene::parse(&object(line), "x.toml").unwrap_err().0;
            assert!(
                e.contains("x.toml") && e.contains(line) && e.contains("array of 3 numbers"),
                "{e}"
            );
        }
        let top = "name = \"x\"\ngravity = [0.0, -9.81, 0.0, 1.0]\n[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\nspacing = 0.02\n";
        let e = Scene::parse(top, "x.toml").unwrap_err().0;
        assert!(
            e.contains("gravity") && e.contains("array of 3 numbers"),
            "{e}"
        );
        let plane = "name = \"x\"\n[[objects]]\nstatic = true\nshape = { type = \"plane\", size = [1.0, 1.0, 1.0] }\nspacing = 0.02\n";
        let e = Scene::parse(plane, "x.toml").unwrap_err().0;
        assert!(e.contains("array of 2 numbers"), "{e}");
        let fixed = object("fixed = [{ min = [0.0, 0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0] }]");
        let e = Scene::parse(&fixed, "x.toml").unwrap_err().0;
        assert!(e.contains("array of 3 numbers"), "{e}");
        let camera = "name = \"x\"\n[camera]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0, 0.0]\n[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\nspacing = 0.02\n";
        let e = Scene::parse(camera, "x.toml").unwrap_err().0;
        assert!(e.contains("array of 3 numbers"), "{e}");
    }

    /// A phyxel's mass is its cell volume times the density (kg): values each in range
    /// whose product underflows f32 (a lattice of 1e-14 m at 1e-6 kg/m³: 1e-48 kg) are
    /// refused naming the density and the spacing; `Object::new` panicked on a mass of 0
    /// (and on an infinite one, which `material::DENSITY_RANGE` now keeps out).
    #[test]
    fn phyxel_masses_out_of_range_are_refused() {
        let text = "name = \"x\"\n[[objects]]\nshape = { type = \"sphere\", radius = 5e-14 }\n\
                    spacing = 1e-14\nmaterial = { density = 1e-6 }\n";
        let scene = Scene::parse(text, "x.toml").expect("each value in range");
        let e = scene.build(&BuildOptions::default()).unwrap_err().0;
        assert!(
            e.contains("objects[0]")
                && e.contains("material.density = 1e-6")
                && e.contains("spacing = 0.00000000000001")
                && e.contains("mass of 0e0 kg"),
            "{e}"
        );
    }

    /// Shapes thin for their extent are refused before sampling, where their volume and
    /// area alone underestimated the lattice: a needle 2 km long and 1 µm thick at 0.2
    /// mm spacing has one row of 10⁷ phyxels (it exhausted memory), a 600 m torus of 1 µm
    /// tube tests 9·10¹² lattice points (it ran for hours), and a plane 1 µm deep is one
    /// row too.
    #[test]
    fn thin_shapes_are_refused_before_sampling() {
        let one = |shape: &str, extra: &str| {
            let text = format!(
                "name = \"x\"\n[[objects]]\n{extra}\nshape = {shape}\nspacing = 2e-4\n\
                 surfel_spacing = 0.01\n"
            );
            let scene = Scene::parse(&text, "x.toml").expect("parses");
            scene.build(&BuildOptions::default()).unwrap_err().0
        };
        let e = one(r#"{ type = "box", size = [2000.0, 1e-6, 1e-6] }"#, "");
        assert!(
            e.contains("spacing = 0.0002") && e.contains("about 1.02e7 phyxels"),
            "{e}"
        );
        let e = one(r#"{ type = "torus", major = 300.0, minor = 1e-6 }"#, "");
        assert!(e.contains("9.00e12 lattice points"), "{e}");
        let e = one(
            r#"{ type = "plane", size = [2000.0, 1e-6] }"#,
            "static = true",
        );
        assert!(e.contains("about 1.01e7 phyxels"), "{e}");
    }

    /// A phyxel count asked of a needle (2 m × 0.1 mm × 0.1 mm) is met within 10%: the
    /// spacing search starts near the needle's own estimate, not from its volume alone
    /// (whose spacing put 7,400 phyxels on it, and eight cube-root corrections of a count
    /// that goes as 1/spacing left 1,124).
    #[test]
    fn a_needle_gets_its_phyxel_count() {
        let text = "name = \"x\"\n[[objects]]\nshape = { type = \"box\", size = [2.0, 1e-4, 1e-4] }\n\
                    phyxels = 1000\nsurfel_spacing = 0.01\n";
        let scene = Scene::parse(text, "x.toml").expect("parses");
        let world = scene.build(&BuildOptions::default()).expect("builds");
        let n = world.objects[0].phyxels.len();
        assert!((900..=1100).contains(&n), "{n} phyxels");
    }

    /// The default dt is 90% of the stable bound, at most 1 ms (`MAX_DEFAULT_DT`): a
    /// material of 1.2e-38 Pa has a bound of about 10¹⁸ s, and at that dt its sphere
    /// fell past f32's range by the fourth step; at 1 ms it falls ½ g t² (m) like any
    /// body, within 1% after 50 steps (symplectic Euler's discrete drop, g dt² n(n+1)/2).
    #[test]
    fn the_default_dt_is_at_most_a_millisecond() {
        let text = "name = \"x\"\n[[objects]]\nshape = { type = \"sphere\", radius = 0.1 }\n\
                    spacing = 0.025\nmaterial = { young = 1.2e-38 }\n";
        let mut world = Scene::parse(text, "x.toml")
            .unwrap()
            .build(&BuildOptions::default())
            .unwrap();
        assert!(world.stable_dt().0 > 1e15, "bound {}", world.stable_dt().0);
        assert_eq!(world.dt, crate::world::MAX_DEFAULT_DT);
        let y0 = world.objects[0].phyxels.centre_of_mass()[1];
        let n = 50u64;
        for _ in 0..n {
            world.step();
        }
        assert!(world.all_finite());
        let drop = y0 - world.objects[0].phyxels.centre_of_mass()[1];
        let want = 9.81 * 1e-6 * (n * (n + 1) / 2) as f64;
        assert!(
            (drop - want).abs() < 1e-2 * want,
            "dropped {drop} m, want {want} m"
        );
    }

    /// Names must tell objects apart, the names given to unnamed objects (`object{k}`)
    /// included: an explicit `object1` on objects[0] beside an unnamed objects[1] made
    /// two bodies called 'object1'.
    #[test]
    fn generated_names_do_not_collide() {
        let two = |a: &str, b: &str| {
            let obj = |name: &str, x: f32| {
                format!(
                    "[[objects]]\n{name}\nshape = {{ type = \"sphere\", radius = 0.1 }}\nspacing = 0.02\nposition = [{x}, 0.0, 0.0]\n"
                )
            };
            format!("name = \"x\"\n{}{}", obj(a, 0.0), obj(b, 1.0))
        };
        for (a, b, needle) in [
            ("name = \"object1\"", "", "\"object1\""),
            ("", "name = \"object0\"", "unnamed objects[0]"),
            ("name = \"a\"", "name = \"a\"", "objects[0] has it too"),
        ] {
            let e = Scene::parse(&two(a, b), "x.toml").unwrap_err().0;
            assert!(e.contains("objects[1].name") && e.contains(needle), "{e}");
        }
        assert!(Scene::parse(&two("", ""), "x.toml").is_ok());
        assert!(Scene::parse(&two("name = \"object0\"", ""), "x.toml").is_ok());
    }

    /// Mean distance between consecutively stored points (m).
    fn mean_gap(p: &[Vec3]) -> f32 {
        p.windows(2).map(|w| w[0].distance(w[1])).sum::<f32>() / (p.len() - 1) as f32
    }

    /// A built object's surfels are its shape's sample, bit for bit, stored in Morton
    /// order: consecutive surfels lie on average within 3 surfel spacings of each other,
    /// where the sphere sampler's spiral order puts them tens of spacings apart.
    #[test]
    fn surfels_are_the_sample_in_spatial_order() {
        let scene = Scene::builtin("two-spheres").expect("builtin");
        let spec = &scene.objects[0];
        let (rot, pos) = spec.placement();
        let (_, spacing) = spec.spacings(&spec.shape).expect("spacings");
        let sample: Vec<Vec3> = spec
            .shape
            .sample_surface(spacing)
            .positions
            .iter()
            .map(|&p| rot * p + pos)
            .collect();
        let object = spec.build(0, "mls").expect("builds");
        let stored = object.surfels.rest.to_vec();
        let bits = |v: &[Vec3]| {
            let mut b: Vec<[u32; 3]> = v.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
            b.sort_unstable();
            b
        };
        assert_eq!(
            bits(&stored),
            bits(&sample),
            "not a permutation of the sample"
        );
        let (gap, spiral_gap) = (mean_gap(&stored), mean_gap(&sample));
        assert!(
            gap < 3.0 * spacing && spiral_gap > 10.0 * spacing,
            "mean gap {gap:.3e} m stored, {spiral_gap:.3e} m sampled, spacing {spacing:.3e} m"
        );
    }
}
