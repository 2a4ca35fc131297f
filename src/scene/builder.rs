//! Scenes from code: [`Scene::new`] and [`ObjectSpec::new`] hold a scene file's
//! defaults, and chained setters change what a file would spell out. The result builds
//! through [`Scene::build`], the path a file takes: the same checks (overlapping
//! bodies, sampling, memory, a `dt` above the stable bound), the same sampling per
//! backend, and the stable `dt` when none is given.
//!
//! ```
//! use phyxel::scene::{BuildOptions, ObjectSpec, Scene};
//!
//! let ball = |name: &str, x: f32, vx: f32| {
//!     let at = ObjectSpec::sphere(0.1).named(name).phyxels(500);
//!     at.position([x, 0.0, 0.0]).velocity([vx, 0.0, 0.0])
//! };
//! let scene = Scene::new("two balls")
//!     .gravity([0.0; 3])
//!     .object(ball("left", -0.15, 1.0))
//!     .object(ball("right", 0.15, -1.0));
//! let world = scene.build(&BuildOptions::default()).unwrap();
//! assert_eq!(world.objects.len(), 2);
//! assert!(world.dt <= world.stable_dt().0);
//! ```

use super::{ObjectSpec, Output, Preset, Refine, Region, Scene, default_gravity, default_steps};
use crate::body::shape::Shape;
use crate::material::Material;

impl Scene {
    /// A scene named `name` with no objects and a scene file's defaults: 1,000 steps,
    /// gravity 9.81 m/s² down y, `dt` the stable one, frames every 10 steps, the
    /// default preset, sleeping on.
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            description: String::new(),
            dt: None,
            steps: default_steps(),
            gravity: default_gravity(),
            output: Output::default(),
            camera: None,
            preset: Preset::default(),
            resampled_forces: None,
            pairs_in_order: None,
            sleep: None,
            objects: Vec::new(),
        }
    }

    /// Gravitational acceleration (m/s²).
    pub fn gravity(mut self, gravity: [f32; 3]) -> Self {
        self.gravity = gravity;
        self
    }

    /// Time step (s); without one, [`Scene::build`] takes the stable one.
    pub fn dt(mut self, dt: f32) -> Self {
        self.dt = Some(dt);
        self
    }

    /// Steps `phyxel run` takes.
    pub fn steps(mut self, steps: u64) -> Self {
        self.steps = steps;
        self
    }

    /// Adds an object.
    pub fn object(mut self, object: ObjectSpec) -> Self {
        self.objects.push(object);
        self
    }
}

impl ObjectSpec {
    /// An object of `shape` with a scene file's defaults: named by its place in the
    /// scene, surfels at half the phyxel spacing, `mls`, at the origin at rest, the
    /// default [`Material`]. As in a file, the sampling is the one thing to give:
    /// [`ObjectSpec::spacing`] or [`ObjectSpec::phyxels`].
    pub fn new(shape: Shape) -> Self {
        Self {
            name: String::new(),
            shape,
            spacing: 0.0,
            surfel_spacing: None,
            phyxels: None,
            surfels: None,
            influence: None,
            backend: None,
            is_static: false,
            position: [0.0; 3],
            rotation: [0.0; 3],
            velocity: [0.0; 3],
            material: Material::default(),
            fixed: Vec::new(),
            refine: Vec::new(),
            load: [0.0; 3],
            load_ramp: 0.0,
            self_collision: false,
        }
    }

    /// A sphere of `radius` (m).
    pub fn sphere(radius: f32) -> Self {
        Self::new(Shape::Sphere { radius })
    }

    /// A box of edge lengths `size` (m).
    pub fn cuboid(size: [f32; 3]) -> Self {
        Self::new(Shape::Box { size })
    }

    /// A capsule along y: `radius` and the `length` of its straight part (m).
    pub fn capsule(radius: f32, length: f32) -> Self {
        Self::new(Shape::Capsule { radius, length })
    }

    /// A torus about y: `major` and `minor` radii (m).
    pub fn torus(major: f32, minor: f32) -> Self {
        Self::new(Shape::Torus { major, minor })
    }

    /// A static ground plane of `size` (m, x by z), its top face at the position.
    pub fn plane(size: [f32; 2]) -> Self {
        Self::new(Shape::Plane { size }).fixed_in_space()
    }

    /// A mesh or oriented point cloud read from `path` (`.obj`, `.ply`, `.stl`; relative
    /// to the working directory), scaled by 1 and centred on its bounding box.
    pub fn mesh(path: impl Into<String>) -> Self {
        Self::new(Shape::Mesh {
            path: path.into(),
            scale: 1.0,
            mesh: None,
        })
    }

    /// Its name (unique in a scene).
    pub fn named(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// Centre position (m).
    pub fn position(mut self, position: [f32; 3]) -> Self {
        self.position = position;
        self
    }

    /// Rotation: Euler angles in degrees about x, then y, then z.
    pub fn rotation(mut self, degrees: [f32; 3]) -> Self {
        self.rotation = degrees;
        self
    }

    /// Initial velocity (m/s).
    pub fn velocity(mut self, velocity: [f32; 3]) -> Self {
        self.velocity = velocity;
        self
    }

    /// Phyxel lattice spacing (m).
    pub fn spacing(mut self, spacing: f32) -> Self {
        self.spacing = spacing;
        self
    }

    /// A target phyxel count, instead of a spacing: the spacing `(volume / n)^(1/3)`.
    pub fn phyxels(mut self, n: u32) -> Self {
        self.phyxels = Some(n);
        self
    }

    /// Surfel spacing (m).
    pub fn surfel_spacing(mut self, spacing: f32) -> Self {
        self.surfel_spacing = Some(spacing);
        self
    }

    /// Dynamics backend by name (`mls`, `mls-implicit`, `sph`, `lj`, `kinematic`, ...).
    pub fn backend(mut self, name: impl Into<String>) -> Self {
        self.backend = Some(name.into());
        self
    }

    /// Its material.
    pub fn material(mut self, material: Material) -> Self {
        self.material = material;
        self
    }

    /// Young's modulus (Pa), the rest of the material unchanged.
    pub fn young(mut self, young: f32) -> Self {
        self.material.young = young;
        self
    }

    /// A static object: it never moves (grounds, walls, obstacles).
    pub fn fixed_in_space(mut self) -> Self {
        self.is_static = true;
        self
    }

    /// Holds the phyxels inside the box `min`..`max` (object coordinates, m) in place.
    pub fn anchored(mut self, min: [f32; 3], max: [f32; 3]) -> Self {
        self.fixed.push(Region { min, max });
        self
    }

    /// Samples the zone of `refine` finer (graded sampling, [`Refine`]).
    pub fn refined(mut self, refine: Refine) -> Self {
        self.refine.push(refine);
        self
    }

    /// A constant external force on the body (N), spread over its free phyxels by mass.
    pub fn load(mut self, force: [f32; 3]) -> Self {
        self.load = force;
        self
    }
}
