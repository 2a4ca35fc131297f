//! Checks of a scene before it is built: every value, with errors that name the file,
//! the field and the value; the hard limits of sampling and coordinates.

use super::*;
use crate::body::shape::graded;

impl Scene {
    /// Checks every value; errors name the file, the field and the value.
    pub fn validate(&self, origin: &str) -> Result<(), SceneError> {
        let err = |field: &str, msg: String| SceneError(format!("{origin}: {field}: {msg}"));
        self.check_settings().map_err(|(field, m)| err(field, m))?;
        for (k, o) in self.objects.iter().enumerate() {
            let at = format!("objects[{k}]");
            self.check_name(k)
                .map_err(|m| err(&format!("{at}.name"), m))?;
            o.check()
                .map_err(|(key, m)| err(&format!("{at}.{key}"), m))?;
            self.check_near(k)
                .map_err(|(key, m)| err(&format!("{at}.{key}"), m))?;
        }
        Ok(())
    }

    /// Object `j`'s name as the world gives it: its `name`, or `object<j>`.
    pub(super) fn object_name(&self, j: usize) -> String {
        match self.objects[j].name.as_str() {
            "" => format!("object{j}"),
            name => name.to_string(),
        }
    }

    /// A `refine` zone `near` an object names another object of the scene.
    fn check_near(&self, k: usize) -> Result<(), KeyError> {
        let named = |j: usize| self.object_name(j);
        for (r, zone) in self.objects[k].refine.iter().enumerate() {
            let Some(near) = &zone.near else { continue };
            if !(0..self.objects.len()).any(|j| j != k && named(j) == *near) {
                let others: Vec<String> = (0..self.objects.len())
                    .filter(|&j| j != k)
                    .map(named)
                    .collect();
                return at(
                    &format!("refine[{r}].near"),
                    format!(
                        "near = {near:?}: no other object is called so (the others: {})",
                        if others.is_empty() {
                            "none".to_string()
                        } else {
                            others.join(", ")
                        }
                    ),
                );
            }
        }
        Ok(())
    }

    /// The scene-wide settings: dt, gravity, output, camera, and at least one object.
    fn check_settings(&self) -> Result<(), (&'static str, String)> {
        if let Some(dt) = self.dt
            && !(dt.is_finite() && dt > 0.0)
        {
            return Err(("dt", format!("dt = {dt}: must be a finite number > 0")));
        }
        if self.gravity.iter().any(|g| !g.is_finite()) {
            return Err((
                "gravity",
                format!("gravity = {:?}: must be finite", self.gravity),
            ));
        }
        if self.output.every == 0 {
            return Err(("output.every", "every = 0: must be >= 1".into()));
        }
        if let Some(c) = &self.camera {
            c.validate().map_err(|m| ("camera", m))?;
        }
        if self.objects.is_empty() {
            return Err(("objects", "the scene has no [[objects]]".into()));
        }
        Ok(())
    }

    /// Object `k`'s name is its own. Messages, summaries and fragments name objects: two
    /// of one name would be ambiguous in all three. An unnamed object is called
    /// `object{k}` when built, which an explicit name may take.
    fn check_name(&self, k: usize) -> Result<(), String> {
        let o = &self.objects[k];
        // Names reach terminals, summaries and file headers: a control character (an
        // escape sequence, a NUL, a newline) would act there instead of being read.
        if o.name.chars().any(char::is_control) {
            return Err(format!(
                "name = {:?}: holds a control character; use printable characters",
                o.name
            ));
        }
        let named = |j: usize| self.object_name(j);
        let name = named(k);
        let Some(first) = (0..k).find(|&j| named(j) == name) else {
            return Ok(());
        };
        Err(
            match (o.name.is_empty(), self.objects[first].name.is_empty()) {
                (false, false) => format!("name = \"{name}\": objects[{first}] has it too"),
                (false, true) => format!(
                    "name = \"{name}\": the unnamed objects[{first}] is called so; \
                     choose another name or name objects[{first}]"
                ),
                _ => format!(
                    "unnamed, it would be called \"{name}\", as objects[{first}] is \
                     named; give it a name"
                ),
            },
        )
    }
}

/// An error of one object: the key (below `objects[k].`) and the message.
type KeyError = (String, String);

/// `Err((key, message))` for one object's key.
fn at<T>(key: &str, message: String) -> Result<T, KeyError> {
    Err((key.to_string(), message))
}

impl ObjectSpec {
    /// Checks every value of the object; the error names the key.
    fn check(&self) -> Result<(), KeyError> {
        self.shape.validate().map_err(|m| ("shape".into(), m))?;
        self.material
            .validate()
            .and_then(|()| self.material.plastic_keys_used())
            .map_err(|m| ("material".into(), m))?;
        self.check_sampling()?;
        self.check_motion()?;
        self.check_backend()?;
        self.check_fixed()?;
        self.check_refine()?;
        kinematic_keys(self).map_err(|(key, m)| (key.to_string(), m))
    }

    /// Checks every value of the object, as [`Scene::validate`] does for each of its
    /// objects: for a body made outside a scene file (the viewer's drops and tool).
    /// The error is "KEY: message".
    pub fn validate(&self) -> Result<(), String> {
        self.check().map_err(|(key, m)| format!("{key}: {m}"))
    }

    /// Sample counts and spacings: one way to give each, within the limits.
    fn check_sampling(&self) -> Result<(), KeyError> {
        let o = self;
        let size = o.shape.half_extents().max_element() * 2.0;
        for (name, n) in [("phyxels", o.phyxels), ("surfels", o.surfels)] {
            if n == Some(0) {
                return at(name, format!("{name} = 0: must be >= 1"));
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
            return at(
                count,
                format!("both {count} and {spacing} are given: give one of them"),
            );
        }
        for (name, n, limit) in [
            ("phyxels", o.phyxels, MAX_PHYXELS),
            ("surfels", o.surfels, MAX_SURFELS),
        ] {
            sample_count(name, n, limit).map_err(|m| (name.to_string(), m))?;
        }
        if o.is_static {
            static_keys(o).map_err(|(key, m)| (key.to_string(), m))?;
        }
        if o.phyxels.is_some() && o.spacing == 0.0 {
            // The spacing follows from the count once the shape is sampled.
        } else if o.spacing == 0.0 {
            return at(
                "spacing",
                "spacing = 0 (or missing): give a phyxel spacing > 0 (m) or a `phyxels` \
                 count"
                    .into(),
            );
        } else if !(o.spacing.is_finite() && o.spacing > 0.0) {
            return at(
                "spacing",
                format!("spacing = {}: must be a finite number > 0", o.spacing),
            );
        }
        if o.spacing > size {
            return at(
                "spacing",
                format!("spacing = {}: larger than the shape ({size})", o.spacing),
            );
        }
        // Before the position's check: a spacing far too fine for any placement is the
        // spacing's fault (1e-7 m needs 4e18 phyxels; the position check would blame
        // the placement).
        // (A mesh not yet loaded has no size: `n` is infinite, and the check after
        // loading makes it.)
        let n = phyxel_estimate(&o.shape, o.spacing);
        if o.phyxels.is_none() && n.is_finite() && n > MAX_PHYXELS as f64 {
            return at(
                "spacing",
                format!(
                    "spacing = {}: gives about {n:.2e} phyxels, more than the limit of \
                     {MAX_PHYXELS} per object (a coarser spacing, or a count: `phyxels = N`){}",
                    o.spacing,
                    units_hint(&o.shape)
                ),
            );
        }
        if let Some(f) = o.influence
            && !(1.5..=4.0).contains(&f)
        {
            return at(
                "influence",
                format!(
                    "influence = {f}: must be in [1.5, 4] phyxel spacings (2 by default, \
                     3 in the paper): below, a phyxel has too few neighbours for its MLS \
                     gradient; above, the stencils grow by the cube"
                ),
            );
        }
        if let Some(s) = o.surfel_spacing
            && !(s.is_finite() && s > 0.0)
        {
            return at(
                "surfel_spacing",
                format!("surfel_spacing = {s}: must be a finite number > 0"),
            );
        }
        Ok(())
    }

    /// Placement, velocity and load: finite, and a position that f32 resolves.
    fn check_motion(&self) -> Result<(), KeyError> {
        let o = self;
        if o.load_ramp != 0.0 && o.load == [0.0; 3] && !o.is_static {
            return at(
                "load_ramp",
                format!("load_ramp = {}: has no effect without a load", o.load_ramp),
            );
        }
        if !(o.load_ramp.is_finite() && o.load_ramp >= 0.0) {
            return at(
                "load_ramp",
                format!("load_ramp = {}: must be a finite number >= 0", o.load_ramp),
            );
        }
        let vecs = [
            ("position", o.position),
            ("rotation", o.rotation),
            ("velocity", o.velocity),
            ("load", o.load),
        ];
        for (name, v) in vecs {
            if v.iter().any(|c| !c.is_finite()) {
                return at(name, format!("{name} = {v:?}: must be finite"));
            }
        }
        // f32 coordinates must resolve the object's finest spacing where it stands:
        // far out they round distances to 0 (zero phyxel spacings) or motion away.
        // (The offset only: a spacing too fine for the shape's own size is the
        // sample-count limit's business.)
        let size = o.shape.half_extents().max_element() * 2.0;
        let phyxel_spacing = if o.spacing > 0.0 { o.spacing } else { size };
        let fine = phyxel_spacing.min(o.surfel_spacing.unwrap_or(f32::INFINITY));
        let reach = o.position.iter().fold(0.0f32, |m, c| m.max(c.abs()));
        let resolution = reach * f32::EPSILON;
        if resolution > POSITION_RESOLUTION * fine {
            return at(
                "position",
                format!(
                    "position = {:?}: too far from the origin for f32 coordinates: there \
                     they resolve {resolution:.2e} m, more than 1/{} of the finest \
                     spacing {fine} m; move the scene nearer the origin",
                    o.position,
                    (1.0 / POSITION_RESOLUTION).round()
                ),
            );
        }
        Ok(())
    }

    /// A known backend, and one that models plastic flow for a plastic material.
    fn check_backend(&self) -> Result<(), KeyError> {
        let o = self;
        if let Some(b) = o.backend.as_deref().filter(|_| o.material.is_plastic())
            && !backends::PLASTIC.contains(&b)
        {
            return at(
                "backend",
                format!(
                    "backend = \"{b}\" models no plastic flow, so the material's \
                     plastic_yield and plastic_creep would do nothing (plastic flow: {})",
                    backends::PLASTIC.join(", ")
                ),
            );
        }
        if !o.is_static
            && !backends::NAMES.contains(&o.backend_name())
            && o.backend_name() != backends::KINEMATIC
        {
            return at(
                "backend",
                format!(
                    "backend = \"{}\": unknown (available: {}, {})",
                    o.backend_name(),
                    backends::NAMES.join(", "),
                    backends::KINEMATIC
                ),
            );
        }
        Ok(())
    }

    /// Fixed regions: numbers, with min <= max on each axis.
    fn check_fixed(&self) -> Result<(), KeyError> {
        for (r, reg) in self.fixed.iter().enumerate() {
            if reg.min.iter().chain(&reg.max).any(|c| c.is_nan()) {
                return at(
                    &format!("fixed[{r}]"),
                    format!(
                        "min = {:?}, max = {:?}: must be numbers (not NaN)",
                        reg.min, reg.max
                    ),
                );
            }
            if (0..3).any(|c| reg.min[c] > reg.max[c]) {
                return at(
                    &format!("fixed[{r}]"),
                    format!(
                        "min = {:?}, max = {:?}: min must not exceed max",
                        reg.min, reg.max
                    ),
                );
            }
        }
        Ok(())
    }
}

impl ObjectSpec {
    /// Refined zones: a box or a sphere each, finer than the object's spacing (within
    /// [`graded::MAX_LEVEL`] halvings), touching the shape, on a backend that takes a
    /// graded cloud.
    fn check_refine(&self) -> Result<(), KeyError> {
        if self.refine.is_empty() {
            return Ok(());
        }
        if matches!(self.shape, Shape::Plane { .. }) {
            return at(
                "refine",
                "a plane has one layer of phyxels: there is no volume to refine (refine \
                 the body that touches it)"
                    .into(),
            );
        }
        let backend = self.backend_name();
        if !self.is_static && !backends::GRADED.contains(&backend) {
            return at(
                "refine",
                format!(
                    "backend = \"{backend}\" models a uniform lattice (its kernel or bonds \
                     are defined on one spacing): graded sampling needs {} or {}",
                    backends::mls::NAME,
                    backends::mls::implicit::NAME
                ),
            );
        }
        let half = self.shape.half_extents();
        for (k, r) in self.refine.iter().enumerate() {
            let key = format!("refine[{k}]");
            let numbers = r.min.iter().chain(&r.max).chain(&r.centre).flatten();
            if numbers.chain(&r.radius).any(|c| !c.is_finite()) {
                return at(
                    &key,
                    "min, max, centre and radius must be finite numbers".into(),
                );
            }
            if r.near.is_some() || r.distance.is_some() {
                let alone = r.min.is_none()
                    && r.max.is_none()
                    && r.centre.is_none()
                    && r.radius.is_none()
                    && r.near.is_some();
                if !alone {
                    return at(
                        &key,
                        "`near` (with an optional `distance`) replaces a box or a sphere: \
                         give one of them"
                            .into(),
                    );
                }
                if let Some(d) = r.distance
                    && !(d.is_finite() && d >= 0.0)
                {
                    return at(
                        &format!("{key}.distance"),
                        format!("distance = {d}: must be a finite number >= 0"),
                    );
                }
            }
            let zone = r.zone();
            if zone.is_none() && r.near.is_none() {
                return at(
                    &key,
                    "give a box (`min` and `max`), a sphere (`centre` and `radius`) or \
                     `near` an object, not both nor parts of one"
                        .into(),
                );
            }
            match zone {
                Some(graded::Zone::Box { min, max }) if min.cmpgt(max).any() => {
                    return at(
                        &key,
                        format!("min = {min}, max = {max}: min must not exceed max"),
                    );
                }
                Some(graded::Zone::Sphere { radius, .. }) if radius <= 0.0 => {
                    return at(&key, format!("radius = {radius}: must be > 0"));
                }
                _ => {}
            }
            if !(r.spacing.is_finite() && r.spacing > 0.0) {
                return at(
                    &format!("{key}.spacing"),
                    format!("spacing = {}: must be a finite number > 0", r.spacing),
                );
            }
            // With `phyxels = N` the base spacing is known once sampled (the build checks).
            if self.spacing > 0.0 {
                if r.spacing >= self.spacing {
                    return at(
                        &format!("{key}.spacing"),
                        format!(
                            "spacing = {}: not finer than the object's spacing {}: a zone \
                             refines",
                            r.spacing, self.spacing
                        ),
                    );
                }
                let finest = self.spacing / (1u32 << graded::MAX_LEVEL) as f32;
                if r.spacing < finest * 0.999 {
                    return at(
                        &format!("{key}.spacing"),
                        format!(
                            "spacing = {}: more than {} times finer than the object's \
                             spacing {} (at most {finest})",
                            r.spacing,
                            1u32 << graded::MAX_LEVEL,
                            self.spacing
                        ),
                    );
                }
            }
            // A `near` zone is placed, and checked so, by the build.
            if let Some(zone) = zone
                && zone.distance_to_box(-half, half) > 0.0
            {
                return at(
                    &key,
                    format!(
                        "{zone:?} lies outside the shape's bounding box (half extents \
                         {half}; object-local coordinates, before rotation): it refines \
                         nothing"
                    ),
                );
            }
        }
        if self.spacing > 0.0 {
            let n = phyxel_estimate(&self.shape, self.spacing)
                + refined_estimate(&self.shape, self.spacing, &self.refine);
            if n.is_finite() && n > MAX_PHYXELS as f64 {
                return at(
                    "refine",
                    format!(
                        "the zones give about {n:.2e} phyxels, more than the limit of \
                         {MAX_PHYXELS} per object: smaller zones or coarser spacings in them"
                    ),
                );
            }
        }
        Ok(())
    }
}

/// About how many phyxels a graded sampling adds to the uniform lattice's
/// ([`phyxel_estimate`]): per level, the zone grown by its band times the finer cells'
/// density over the coarser's, each capped at the shape's volume.
pub(super) fn refined_estimate(shape: &Shape, spacing: f32, refine: &[Refine]) -> f64 {
    let volume = shape.volume() as f64;
    let grading = graded::Grading {
        base: spacing,
        zones: Vec::new(),
    };
    let mut extra = 0.0;
    for r in refine {
        let Some(zone) = r.zone() else { continue };
        for level in 1..=grading.level_of(r.spacing) {
            let coarse = spacing as f64 / (1u64 << (level - 1)) as f64;
            let grow = (graded::GRADE as f64 + 1.0) * coarse;
            let zone_volume = match zone {
                graded::Zone::Box { min, max } => (max - min)
                    .as_dvec3()
                    .to_array()
                    .iter()
                    .map(|e| e + 2.0 * grow)
                    .product::<f64>(),
                graded::Zone::Sphere { radius, .. } => {
                    4.0 / 3.0 * std::f64::consts::PI * (radius as f64 + grow).powi(3)
                }
            };
            extra += zone_volume.min(volume) * 7.0 / coarse.powi(3);
        }
    }
    extra
}

/// Finest f32 resolution allowed at an object's position, as a fraction of its finest
/// spacing (`Scene::validate`): a millimetre-spaced object may stand up to about 10 m
/// from the origin, a 4 cm-spaced one about 300 m. Further out, f32 rounds phyxel
/// spacings to 0 and per-step motions away (a body at 50 km does not move at 1 m/s).
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
/// across at 0.2 mm spacing would test 10¹³ (hours) to keep a few thousand.
pub const MAX_LATTICE_POINTS: f64 = 2e9;
/// Most winding-number terms sampling one mesh's volume may take
/// ([`Shape::inside_test_work`]: lattice points × triangles, about 16 ns each on two
/// cores: some 30 s; 2.9e9 terms take 47 s). A 2-million-triangle mesh at 0.01 m would
/// run for over a minute.
pub const MAX_INSIDE_TEST_WORK: f64 = 2e9;

/// About how many phyxels the lattice of `spacing` puts into `shape`: the volume's
/// cells, the boundary layer's (area / spacing²), and one row along the longest extent,
/// which a needle thinner than the spacing still gets (volume and area alone count
/// 10⁵ phyxels for a 2 km needle that samples 10⁷).
pub(super) fn phyxel_estimate(shape: &Shape, spacing: f32) -> f64 {
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

/// Every float in `value` (at `path`) within the range of normal f32 numbers (or 0,
/// or not finite, which the field checks report); `Err` names the key and the value.
pub(super) fn f32_range(path: &str, value: &toml::Value) -> Result<(), String> {
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

/// Refuses a target count `name = n` above `limit`.
pub(super) fn sample_count(name: &str, n: Option<u32>, limit: usize) -> Result<(), String> {
    match n {
        Some(n) if n as usize > limit => Err(format!(
            "{name} = {n}: more than the limit of {limit} per object"
        )),
        _ => Ok(()),
    }
}

/// A static object never moves: the keys that only act on moving objects are refused,
/// `Err((key, message))`, rather than ignored.
/// A kinematic body follows its path rigidly: anchors, loads, self-collision, breaking
/// and flow would do nothing to it (or, anchors, stretch it), so they are errors.
fn kinematic_keys(o: &ObjectSpec) -> Result<(), (&'static str, String)> {
    if o.is_static || o.backend_name() != backends::KINEMATIC {
        return Ok(());
    }
    let idle = "has no effect on a kinematic body (it moves rigidly along its path)";
    if !o.fixed.is_empty() {
        return Err((
            "fixed",
            format!(
                "{} fixed box(es): a kinematic body moves rigidly along its path, and \
                 anchoring part of it would stretch it; leave `fixed` out",
                o.fixed.len()
            ),
        ));
    }
    if o.load != [0.0; 3] {
        return Err(("load", format!("load = {:?}: {idle}", o.load)));
    }
    if o.load_ramp != 0.0 {
        return Err(("load_ramp", format!("load_ramp = {}: {idle}", o.load_ramp)));
    }
    if o.self_collision {
        return Err(("self_collision", format!("self_collision = true: {idle}")));
    }
    if o.material.fracture {
        return Err(("material", format!("fracture = true: {idle}")));
    }
    Ok(())
}

pub(super) fn static_keys(o: &ObjectSpec) -> Result<(), (&'static str, String)> {
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

/// Meshes are read in metres: one that spans more than [`MESH_UNITS_HINT`] metres was
/// most likely drawn in millimetres or centimetres, and its `scale` is the fix the user
/// needs (empty for anything else).
pub(super) fn units_hint(shape: &Shape) -> String {
    let Shape::Mesh { scale, .. } = shape else {
        return String::new();
    };
    let span = 2.0 * shape.half_extents().max_element();
    if span.is_nan() || span <= MESH_UNITS_HINT {
        return String::new();
    }
    format!(
        "; the mesh spans {span} m at scale = {scale}: if its units are millimetres, \
         scale = {:e} makes it {} m (centimetres: {:e})",
        scale * 1e-3,
        span * 1e-3,
        scale * 1e-2
    )
}

/// Span (m) above which a mesh's size error suggests its units ([`units_hint`]).
const MESH_UNITS_HINT: f32 = 10.0;
