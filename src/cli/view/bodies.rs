//! The bodies the viewer adds, removes and grabs: the tool sphere (a kinematic body),
//! dropped spheres, and the grab spring's pick along the mouse ray.

use glam::Vec3;
use phyxel::World;
use phyxel::body::shape::Shape;
use phyxel::dynamics::kinematic::Kinematic;
use phyxel::scene::ObjectSpec;
use phyxel::world::DT_FRACTION;

/// Angular frequency (1/s) of the grab spring on the grabbed body's whole mass: the body
/// follows the mouse within about a sixth of a second, and stays far below the stable
/// rate of any scene's dt.
pub(super) const GRAB_OMEGA: f32 = 2.0 * std::f32::consts::PI * 3.0;

/// Damping ratio of the grab spring (critically damped would lag; 0.7 barely overshoots).
pub(super) const GRAB_DAMPING: f32 = 0.7;

/// Phyxels the grab spring pulls (the nearest to the grabbed point).
const GRAB_PHYXELS: usize = 8;

/// The tool's radius over the size (box diagonal) of the scene's moving bodies.
const TOOL_SIZE: f32 = 0.08;

/// The tool's Young's modulus over the body it copies (only contact reads it).
const TOOL_STIFFNESS: f32 = 10.0;

/// A grab spring.
pub(super) struct Grab {
    pub object: u32,
    pub phyxels: Vec<usize>,
    /// View depth of the grabbed point along the ray.
    pub depth: f32,
    pub target: Vec3,
}

impl Grab {
    /// Mass (kg) and mass-weighted mean position and velocity of the grabbed phyxels in
    /// `p`; `None` once they no longer fit the body (it was replaced or split).
    pub(super) fn mean(&self, p: &phyxel::Phyxels) -> Option<(f32, Vec3, Vec3)> {
        if self.phyxels.iter().any(|&i| i >= p.len()) {
            return None;
        }
        let mass: f32 = self.phyxels.iter().map(|&i| p.mass[i]).sum();
        let weighted = |col: &phyxel::columns::Vec3s| {
            self.phyxels
                .iter()
                .map(|&i| p.mass[i] * col.get(i))
                .sum::<Vec3>()
                / mass
        };
        Some((mass, weighted(&p.pos), weighted(&p.vel)))
    }
}

/// The surfel bounds of an object (m).
pub(super) fn bounds(o: &phyxel::Object) -> Option<(Vec3, Vec3)> {
    let s = &o.surfels;
    (!s.is_empty()).then(|| {
        s.pos
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p), hi.max(p))
            })
    })
}

/// The box of the scene's moving bodies (all bodies when none moves).
pub(super) fn scene_box(world: &World) -> (Vec3, Vec3) {
    let moving = world.objects.iter().any(|o| !o.is_static());
    world
        .objects
        .iter()
        .filter(|o| !moving || !o.is_static())
        .filter_map(bounds)
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (a, b)| {
            (lo.min(a), hi.max(b))
        })
}

/// Where the `n`-th dropped sphere starts: above the scene's moving bodies, a little
/// aside each time so that drops pile rather than stack.
pub(super) fn drop_point(world: &World, n: u32) -> Vec3 {
    let (lo, hi) = scene_box(world);
    let size = (hi - lo).length();
    let angle = n as f32 * 2.4;
    let aside = 0.15 * size * Vec3::new(angle.cos(), 0.0, angle.sin());
    Vec3::new(0.5 * (lo.x + hi.x), hi.y + 0.6 * size, 0.5 * (lo.z + hi.z)) + aside
}

/// Adds a sphere at `at`: the tool (kinematic, sized by [`TOOL_SIZE`]) or a dropped body
/// (the first moving body's material and backend, half its size). Its surfels are as
/// fine as the finest moving body's, so that contact with it is resolved as finely.
/// Returns its id.
pub(super) fn add_body(world: &mut World, at: Vec3, name: &str, tool: bool) -> Result<u32, String> {
    let (lo, hi) = scene_box(world);
    let size = (hi - lo).length().max(1e-3);
    if !size.is_finite() {
        return Err(format!(
            "the scene's bodies span {size} m: no room for a sphere"
        ));
    }
    // The first moving body lends its material and backend; a scene of static bodies
    // only gets the default material on `mls`.
    let template = world
        .objects
        .iter()
        .find(|o| !o.is_static() && o.dynamics_as::<Kinematic>().is_none());
    let surfel_spacing = world
        .objects
        .iter()
        .filter(|o| (template.is_none() || !o.is_static()) && !o.surfels.is_empty())
        .map(|o| o.surfel_spacing)
        .fold(f32::INFINITY, f32::min);
    let radius = if tool {
        TOOL_SIZE * size
    } else {
        template
            .and_then(bounds)
            .map_or(TOOL_SIZE * size, |(a, b)| 0.25 * (b - a).max_element())
    };
    let mut material = template.map_or_else(Default::default, |t| t.material.clone());
    if tool {
        // A probe stiffer than the tissue it presses (contact stiffness grows with both).
        material.young *= TOOL_STIFFNESS;
    }
    let backend = if tool {
        phyxel::backends::KINEMATIC.to_string()
    } else {
        template
            .map_or(phyxel::backends::mls::NAME, |t| t.dynamics.name())
            .to_string()
    };
    let spec = ObjectSpec {
        name: name.to_string(),
        shape: Shape::Sphere { radius },
        spacing: radius / if tool { 2.5 } else { 4.0 },
        surfel_spacing: Some(surfel_spacing.max(radius / 25.0)),
        phyxels: None,
        surfels: None,
        influence: None,
        backend: Some(backend.clone()),
        is_static: false,
        position: at.to_array(),
        rotation: [0.0; 3],
        velocity: [0.0; 3],
        material,
        fixed: Vec::new(),
        refine: Vec::new(),
        load: [0.0; 3],
        load_ramp: 0.0,
        self_collision: false,
    };
    // As a scene file's object: finite, and where f32 resolves its spacing.
    spec.validate()?;
    if !tool && let Some(other) = overlapped(world, at, radius) {
        return Err(format!(
            "a sphere of radius {radius:.3e} m at {at} would overlap '{other}': drop it \
             elsewhere (contact resolves touching surfaces, not bodies inside one another)"
        ));
    }
    let id = world
        .objects
        .iter()
        .map(|o| o.id)
        .max()
        .map_or(0, |m| m + 1);
    let mut object = spec.build(id, &backend)?;
    if let Some(k) = object.dynamics_mut::<Kinematic>() {
        k.target = Some(at);
        k.max_speed = (4.0 * size).max(0.5);
    }
    world.objects.push(object);
    // A new body may bound the step more tightly.
    let (bound, _) = world.stable_dt();
    if bound.is_finite() && bound > 0.0 && bound < world.dt {
        world.dt = bound * DT_FRACTION;
    }
    Ok(id)
}

/// The name of a body that a sphere of `radius` at `at` would overlap: one with a phyxel
/// inside the sphere, widened by half that body's phyxel spacing (so that a sphere
/// wholly inside a coarsely sampled body is found too).
fn overlapped(world: &World, at: Vec3, radius: f32) -> Option<&str> {
    world.objects.iter().find_map(|o| {
        let p = &o.phyxels;
        (0..p.len())
            .any(|i| p.pos.get(i).distance(at) < radius + 0.5 * p.spacing[i])
            .then_some(o.name.as_str())
    })
}

/// Removes body `id`; the contact lists, which index objects, are dropped with it (the
/// next step finds them again).
pub(super) fn remove_body(world: &mut World, id: u32) {
    world.objects.retain(|o| o.id != id);
    world.contact.pairs.clear();
    world.contact.detections.clear();
    world.contact.patches.clear();
}

/// The moving body whose surfel the ray (eye, unit `dir`) meets first (within its disc
/// radius, doubled: a thin body is still caught), with its nearest phyxels.
pub(super) fn pick(world: &World, eye: Vec3, dir: Vec3) -> Option<Grab> {
    let mut best: Option<(f32, usize, Vec3, bool)> = None;
    for (k, o) in world.objects.iter().enumerate() {
        // Static bodies hide what is behind them but cannot be grabbed; nor the tool.
        let grabbable = !o.is_static() && o.dynamics_as::<Kinematic>().is_none();
        let s = &o.surfels;
        for i in 0..s.len() {
            let q = s.pos.get(i) - eye;
            let t = q.dot(dir);
            let r = 2.0 * s.radius[i];
            if t > 0.0 && (q - t * dir).length_squared() < r * r && best.is_none_or(|b| t < b.0) {
                best = Some((t, k, s.pos.get(i), grabbable));
            }
        }
    }
    let (depth, k, point, grabbable) = best?;
    if !grabbable {
        return None;
    }
    let o = &world.objects[k];
    let p = &o.phyxels;
    let mut near: Vec<usize> = (0..p.len()).collect();
    near.sort_by(|&a, &b| {
        let da = (p.pos.get(a) - point).length_squared();
        let db = (p.pos.get(b) - point).length_squared();
        da.total_cmp(&db)
    });
    near.truncate(GRAB_PHYXELS);
    near.retain(|&i| p.fixed[i] == 0);
    (!near.is_empty()).then_some(Grab {
        object: o.id,
        phyxels: near,
        depth,
        target: point,
    })
}
