//! A point-based object `Γ = (S, P)`: surfels, phyxels, a material and a backend.

use crate::body::advect::SurfelBinding;
use crate::body::connectivity::Connectivity;
use crate::body::output_mesh::OutputMesh;
use crate::body::self_collision::SelfCollision;
use crate::dynamics::Dynamics;
use crate::dynamics::gradient::MlsStencil;
use crate::material::Material;
use crate::points::phyxels::Phyxels;
use crate::points::surfels::Surfels;
use crate::spatial::broad_phase::Aabb;
use glam::Mat3;

/// Support of the contact-force distribution kernel in influence radii. The paper uses
/// two of Müller's radii (3 r each, so 6 phyxel spacings); that spreads a contact force
/// over most of a small body, which then decelerates almost rigidly while the surfaces
/// overlap. One of our radii (2 r) keeps the force at the surface, where the elastic
/// response should start, and still reaches about 30 phyxels (docs/ARCHITECTURE.md).
pub const DISTRIBUTION_SUPPORT: f32 = 1.0;

/// One simulated object.
pub struct Object {
    /// Stable id (index at creation; fragments get new ids).
    pub id: u32,
    pub name: String,
    pub surfels: Surfels,
    pub phyxels: Phyxels,
    pub material: Material,
    /// The backend. Replace it with [`Object::set_dynamics`], which also reads whether
    /// it joins the implicit solve ([`Object::is_implicit`]; the step reads that anew).
    pub dynamics: Box<dyn Dynamics>,
    /// The backend gives the operators of the implicit solve ([`Dynamics::implicit`]).
    implicit: bool,
    pub(crate) binding: SurfelBinding,
    /// Core MLS gradient estimate for backends that provide none (built on first use).
    pub(crate) estimate: Option<(MlsStencil, Vec<Mat3>)>,
    /// Mean surfel spacing at rest (m): `√(π/2)` × mean disk radius.
    pub surfel_spacing: f32,
    /// Mean phyxel spacing `r_i` at rest (m).
    pub phyxel_spacing: f32,
    /// Surfels that carry contact forces (see [`FORCE_CARRIER_SPACING`]): a fixed subset,
    /// so a carrier enters and leaves a contact at zero depth and forces stay continuous.
    pub force_carrier: Vec<bool>,
    /// Spacing of the force carriers (m): the surfel spacing or the carrier spacing,
    /// whichever is larger.
    pub carrier_spacing: f32,
    /// Largest phyxel influence radius (m).
    pub max_influence: f32,
    /// Largest influence radius of the phyxels that contact forces are sized for: all
    /// of them, or a graded body's finest level ([`Object::use_finest_level`]). The
    /// distribution's support follows it.
    pub contact_influence: f32,
    /// Sampled finer in places ([`Object::use_finest_level`]): the contact spacings
    /// are its finest level's, and a fragment keeps them.
    pub graded: bool,
    /// Support of the contact-force distribution in influence radii (default
    /// [`DISTRIBUTION_SUPPORT`]; the paper 2).
    pub distribution_support: f32,
    /// External load (N) spread over the free phyxels by mass; see [`Object::apply_load`].
    pub load: glam::Vec3,
    /// Ramp time of the load (s).
    pub load_ramp: f32,
    /// For a fragment: the id of the object it broke off from. Fragments never merge
    /// again; they meet only through the contact pipeline.
    pub parent: Option<u32>,
    /// Rest neighbours and penalty of the self-collision force (paper §8), for objects
    /// whose scene asks for it (`self_collision = true`); `None`: no self-collision work.
    pub self_collision: Option<SelfCollision>,
    /// The triangle mesh that follows the phyxels for mesh frames (a `mesh` shape's own
    /// triangles; `None`: the object has none, and a fragment of a fracture loses it).
    pub mesh: Option<OutputMesh>,
    /// The fracture check's state (empty unless the object may break: see
    /// [`crate::body::fracture::may_fracture`]).
    pub connectivity: Connectivity,
    /// Unique per `Object::new` in the process: the world keeps a static object's box
    /// and grids for the object it computed them for, and an object replaced by another
    /// of the same id must not inherit them.
    serial: u64,
    /// Asleep (`world::sleep`): not stepped or advected, and not tested for contact
    /// with static objects or other sleeping bodies, until something moving touches it.
    asleep: bool,
    /// The sleep test's state (`world::sleep`).
    pub(crate) still: Stillness,
}

/// The state of a body's sleep test (`world::sleep`): how long it has been still, and
/// where its phyxels have been on average.
#[derive(Clone, Debug, Default)]
pub(crate) struct Stillness {
    /// Seconds the body has been still (the test's clock), and the clock at its last
    /// passed check.
    pub(crate) time: f32,
    pub(crate) checked: f32,
    /// The phyxel positions (with their compensation carry) the displacements are
    /// measured from.
    pub(crate) from: Vec<(glam::Vec3, glam::Vec3)>,
    /// Each phyxel's displacement from `from` summed over the steps of the current
    /// check interval, and those steps.
    pub(crate) sum: Vec<glam::Vec3>,
    pub(crate) steps: u32,
    /// Each phyxel's mean displacement over the first interval (empty until it ends).
    pub(crate) base: Vec<glam::Vec3>,
}

impl Stillness {
    /// Starts the test again from `here` (each phyxel's position and carry), as still
    /// for `time` seconds.
    pub(crate) fn restart(
        &mut self,
        here: impl Iterator<Item = (glam::Vec3, glam::Vec3)>,
        time: f32,
    ) {
        self.from.clear();
        self.from.extend(here);
        self.sum.clear();
        self.sum.resize(self.from.len(), glam::Vec3::ZERO);
        self.steps = 0;
        self.base.clear();
        self.time = time;
        self.checked = time;
    }

    /// Forgets everything: the next step starts the test again.
    pub(crate) fn clear(&mut self) {
        self.from.clear();
        self.time = 0.0;
        self.checked = 0.0;
    }
}

/// The next [`Object::serial`].
static NEXT_SERIAL: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Spacing of the surfels that carry contact forces, in phyxel spacings. Contact
/// forces reach the phyxels through a kernel of about two phyxel spacings, so sampling
/// the contact pressure much finer than the phyxels changes nothing they can feel;
/// surfels finer than an eighth of a phyxel spacing (a million-surfel sphere on 20k
/// phyxels has 17 surfels per phyxel spacing) are still rendered, but only a fixed
/// subset at this spacing is tested for contact (all surfels are when frames are
/// written: `World::render_contacts`), moved onto the contact surface and carries
/// force. An eighth keeps the paper's sampling (about a sixth) untouched; a quarter
/// makes a resting ball jitter (each carrier's area estimate changes as its neighbours
/// enter and leave the contact) (docs/ARCHITECTURE.md).
pub const FORCE_CARRIER_SPACING: f32 = 0.125;

/// The force carriers: all surfels when they are no finer than `carrier_spacing`, else
/// the first surfel (in index order) of each cell of edge `carrier_spacing` at rest.
fn force_carriers(surfels: &Surfels, surfel_spacing: f32, carrier_spacing: f32) -> Vec<bool> {
    let n = surfels.len();
    if carrier_spacing <= surfel_spacing * 1.0001 || carrier_spacing <= 0.0 {
        return vec![true; n];
    }
    let inv = 1.0 / carrier_spacing;
    let mut seen = std::collections::HashSet::with_capacity(n / 4);
    (0..n)
        .map(|i| {
            let p = surfels.rest.get(i) * inv;
            seen.insert([p.x.floor() as i32, p.y.floor() as i32, p.z.floor() as i32])
        })
        .collect()
}

/// A summary (name, backend, counts, spacings, material): the columns themselves are
/// too long to print, and the backend is a trait object.
impl std::fmt::Debug for Object {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Object")
            .field("id", &self.id)
            .field("name", &self.name)
            .field("backend", &self.dynamics.name())
            .field("surfels", &self.surfels.len())
            .field("phyxels", &self.phyxels.len())
            .field("surfel_spacing", &self.surfel_spacing)
            .field("phyxel_spacing", &self.phyxel_spacing)
            .field("material", &self.material)
            .field("parent", &self.parent)
            .finish_non_exhaustive()
    }
}

/// Relative difference allowed between a phyxel's mass and `material.density` times
/// its volume ([`Object::new`]): round-off of the product, not a second density.
pub const MASS_DENSITY_TOLERANCE: f32 = 1e-4;

impl Object {
    /// Radius (m) within which a contact force on this object reaches its phyxels:
    /// [`Object::distribution_support`] influence radii.
    pub fn distribution_radius(&self) -> f32 {
        self.distribution_support * self.contact_influence
    }

    /// Sizes the contact for a graded body's finest level (`phyxel_fine`,
    /// `surfel_fine`: which phyxels and surfels belong to it): the phyxel and surfel
    /// spacings become that level's means, the distribution's support its largest
    /// influence radius, and the force carriers follow. A body is refined where its
    /// contacts are meant to be; a contact on a coarser level then gets the finer
    /// level's penalty (stiffer, and stable, its surface layer being heavier) and its
    /// forces spread over at least the nearest phyxels (docs/ARCHITECTURE.md, "Graded
    /// sampling").
    ///
    /// # Panics
    /// If the masks do not hold one entry per phyxel and surfel, or select none.
    pub fn use_finest_level(&mut self, phyxel_fine: &[bool], surfel_fine: &[bool]) {
        assert_eq!(phyxel_fine.len(), self.phyxels.len(), "one flag per phyxel");
        assert_eq!(surfel_fine.len(), self.surfels.len(), "one flag per surfel");
        let mean = |v: &[f32], fine: &[bool]| {
            let (sum, n) = v
                .iter()
                .zip(fine)
                .filter(|e| *e.1)
                .fold((0.0f32, 0usize), |(s, n), (x, _)| (s + x, n + 1));
            assert!(n > 0, "the finest level holds no sample");
            sum / n as f32
        };
        let phyxel = mean(&self.phyxels.spacing, phyxel_fine);
        let influence = (0..self.phyxels.len())
            .filter(|&i| phyxel_fine[i])
            .map(|i| self.phyxels.radius[i])
            .fold(0.0f32, f32::max);
        let surfel = if self.surfels.is_empty() {
            0.0
        } else {
            mean(&self.surfels.radius, surfel_fine) * std::f32::consts::FRAC_PI_2.sqrt()
        };
        self.set_contact_spacings(phyxel, surfel, influence);
    }

    /// Sets the spacings the contact is sized by (m; see [`Object::use_finest_level`])
    /// and marks the body graded.
    pub fn set_contact_spacings(&mut self, phyxel: f32, surfel: f32, influence: f32) {
        self.phyxel_spacing = phyxel;
        self.surfel_spacing = surfel;
        self.contact_influence = influence;
        self.carrier_spacing = (FORCE_CARRIER_SPACING * phyxel).max(surfel);
        self.force_carrier = force_carriers(&self.surfels, surfel, self.carrier_spacing);
        self.graded = true;
    }

    /// Assembles an object and binds its surfels to its phyxels.
    ///
    /// An object without surfels is allowed (a mass moved by its backend alone) but takes
    /// no part in contact: detection and contact forces act on surfels.
    ///
    /// # Panics
    ///
    /// Without phyxels (surfels follow phyxels, and contact forces act on them), with a
    /// material that [`Material::validate`] refuses, with a non-finite phyxel or surfel
    /// position or surfel normal, with a surfel normal or rest normal that is not a unit
    /// vector (within 1e-3), with columns of the wrong length, or with a mass,
    /// volume, spacing, influence radius or disk radius that is not finite and > 0
    /// ([`Phyxels::check`], [`Surfels::check`]), or with phyxel masses that are not
    /// `material.density` × volume (within [`MASS_DENSITY_TOLERANCE`]): each would turn
    /// the world NaN, or silently freeze or hide part of the object, far from the cause.
    pub fn new(
        id: u32,
        name: impl Into<String>,
        surfels: Surfels,
        phyxels: Phyxels,
        material: Material,
        dynamics: Box<dyn Dynamics>,
    ) -> Self {
        let name = name.into();
        assert!(!phyxels.is_empty(), "Object::new '{name}': no phyxels");
        if let Err(e) = phyxels.check(true) {
            panic!("Object::new '{name}': phyxels.{e}");
        }
        if let Err(e) = surfels.check(true) {
            panic!("Object::new '{name}': surfels.{e}");
        }
        // The backends' bounds and the contact constants read `material.density`, the
        // forces the phyxel masses: they must describe the same body.
        let rho = material.density;
        if let Some(i) = (0..phyxels.len()).find(|&i| {
            let want = rho * phyxels.volume[i];
            (phyxels.mass[i] - want).abs() > MASS_DENSITY_TOLERANCE * want
        }) {
            panic!(
                "Object::new '{name}': phyxel {i} has mass {} kg, but density × volume = {} × {} \
                 = {} kg: build the phyxels with the material's density",
                phyxels.mass[i],
                rho,
                phyxels.volume[i],
                rho * phyxels.volume[i]
            );
        }
        if let Err(e) = material.validate() {
            panic!("Object::new '{name}': invalid material: {e}");
        }
        assert!(
            phyxels.pos.all_finite() && surfels.pos.all_finite() && surfels.normal.all_finite(),
            "Object::new '{name}': a phyxel or surfel position or a surfel normal is not finite"
        );
        // Detection and contact read the normals as directions: a zero normal hides its
        // surfel (two balls with zero normals pass through each other).
        for (column, what) in [
            (&surfels.normal, "normal"),
            (&surfels.rest_normal, "rest normal"),
        ] {
            if let Some(i) =
                (0..surfels.len()).find(|&i| (column.get(i).length() - 1.0).abs() > 1e-3)
            {
                panic!(
                    "Object::new '{name}': surfel {i} has a {what} of length {}: normals must \
                     be unit vectors",
                    column.get(i).length()
                );
            }
        }
        let binding = SurfelBinding::build(&surfels, &phyxels);
        let mean = |v: &[f32]| {
            if v.is_empty() {
                0.0
            } else {
                v.iter().sum::<f32>() / v.len() as f32
            }
        };
        let surfel_spacing =
            mean(&surfels.radius[..surfels.len()]) * std::f32::consts::FRAC_PI_2.sqrt();
        let phyxel_spacing = mean(&phyxels.spacing[..phyxels.len()]);
        let max_influence = phyxels.radius.iter().fold(0.0f32, |a, &b| a.max(b));
        let carrier_spacing = (FORCE_CARRIER_SPACING * phyxel_spacing).max(surfel_spacing);
        let force_carrier = force_carriers(&surfels, surfel_spacing, carrier_spacing);
        let mut object = Self {
            id,
            name,
            surfels,
            phyxels,
            material,
            implicit: false,
            dynamics,
            binding,
            estimate: None,
            surfel_spacing,
            phyxel_spacing,
            force_carrier,
            carrier_spacing,
            max_influence,
            contact_influence: max_influence,
            graded: false,
            distribution_support: DISTRIBUTION_SUPPORT,
            load: glam::Vec3::ZERO,
            load_ramp: 0.0,
            parent: None,
            self_collision: None,
            mesh: None,
            connectivity: Connectivity::default(),
            asleep: false,
            still: Stillness::default(),
            serial: NEXT_SERIAL.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        };
        object.refresh_implicit();
        object
    }

    /// Unique per [`Object::new`] call in the process (see the field).
    pub fn serial(&self) -> u64 {
        self.serial
    }

    /// Makes the current shape the rest shape: rest positions of phyxels and surfels
    /// (and surfel rest normals) become the current ones, the surfels are bound anew and
    /// the backend rebuilds its rest state ([`Dynamics::rest_replaced`]). Surfels stay
    /// where they are: after it, displacements and gradients are zero.
    pub fn renew_rest(&mut self) {
        // The mesh's vertices where the old rest shape's field puts them, before it goes.
        self.follow_mesh();
        self.phyxels.rest = self.phyxels.pos.clone();
        self.surfels.rest = self.surfels.pos.clone();
        self.surfels.rest_normal = self.surfels.normal.clone();
        self.binding = SurfelBinding::build(&self.surfels, &self.phyxels);
        if let Some(m) = &mut self.mesh {
            m.renew_rest(&self.phyxels);
        }
        self.estimate = None;
        self.dynamics.rest_replaced(&self.phyxels, &self.material);
        if self.self_collision.is_some() {
            self.self_collision = Some(SelfCollision::new(&self.phyxels));
        }
    }

    /// Adds the external load at time `t` (s) to the phyxel forces of the next step,
    /// split over the free phyxels in proportion to their mass.
    pub fn apply_load(&mut self, t: f32) {
        if self.load == glam::Vec3::ZERO {
            return;
        }
        let ramp = if self.load_ramp > 0.0 {
            (t / self.load_ramp).min(1.0)
        } else {
            1.0
        };
        let p = &mut self.phyxels;
        let free_mass: f32 = (0..p.len())
            .filter(|&i| p.fixed[i] == 0)
            .map(|i| p.mass[i])
            .sum();
        if free_mass <= 0.0 {
            return;
        }
        let per_kg = self.load * (ramp / free_mass);
        for i in 0..p.len() {
            if p.fixed[i] == 0 {
                let m = p.mass[i];
                p.force.add(i, per_kg * m);
            }
        }
    }

    /// Whether the surfel and phyxel columns still have the counts the object was built
    /// with (its binding, force carriers and backend state are sized by them) and the
    /// padded lengths the SIMD loops read: the columns are public, and replacing them
    /// with another count must be an error that names the object, not an index panic
    /// deep in a phase or a column silently skipped. Also the phyxels' mass, volume,
    /// spacing and radius, and the object's phyxel and carrier spacings and largest
    /// influence radius, finite and > 0, which a caller or a backend may overwrite (a
    /// NaN mass makes the momentum NaN with every position finite; O(phyxels)).
    pub fn check_counts(&self) -> Result<(), String> {
        let (surfels, phyxels) = self.binding.counts();
        let now = (self.surfels.len(), self.phyxels.len());
        if now == (surfels, phyxels) && self.force_carrier.len() == surfels {
            let named = |e: String, what: &str| {
                format!("object '{}' (id {}): {what}.{e}", self.name, self.id)
            };
            self.phyxels.check(true).map_err(|e| named(e, "phyxels"))?;
            // The grids' cells and the contact's spacings derive from these (public)
            // fields: 0 makes a grid panic, and a phyxel spacing of 0 NaN forces. (The
            // surfel spacing is 0 for a fragment without surfels, and only read with
            // surfels.)
            for (field, v) in [
                ("phyxel_spacing", self.phyxel_spacing),
                ("carrier_spacing", self.carrier_spacing),
                ("max_influence", self.max_influence),
                ("contact_influence", self.contact_influence),
            ] {
                if !(v.is_finite() && v > 0.0) {
                    return Err(format!(
                        "object '{}' (id {}): {field} = {v}: must be finite and > 0",
                        self.name, self.id
                    ));
                }
            }
            return self.surfels.check(false).map_err(|e| named(e, "surfels"));
        }
        Err(format!(
            "object '{}' (id {}) has {} surfels and {} phyxels but was built with {surfels} \
             and {phyxels}: build a new Object (Object::new) instead of replacing its columns",
            self.name, self.id, now.0, now.1
        ))
    }

    /// The backend as its concrete type `T`, if it is one (a caller's own backend, or
    /// the [`crate::dynamics::kinematic::Kinematic`] of a tool).
    pub fn dynamics_as<T: Dynamics>(&self) -> Option<&T> {
        let any: &dyn std::any::Any = self.dynamics.as_ref();
        any.downcast_ref::<T>()
    }

    /// The backend as its concrete type `T`, mutably: how a caller drives a kinematic
    /// tool or changes its own backend's parameters between steps.
    pub fn dynamics_mut<T: Dynamics>(&mut self) -> Option<&mut T> {
        let any: &mut dyn std::any::Any = self.dynamics.as_mut();
        any.downcast_mut::<T>()
    }

    /// True for objects whose backend never moves them.
    pub fn is_static(&self) -> bool {
        self.dynamics.is_static()
    }

    /// True while the body sleeps (`World::sleep`): its state is kept, nothing steps it.
    pub fn is_asleep(&self) -> bool {
        self.asleep
    }

    /// True for an object no step moves now: static, or asleep.
    pub fn is_frozen(&self) -> bool {
        self.is_static() || self.asleep
    }

    /// Wakes the body: the next step moves it again (and restarts its still time). Call
    /// it after writing a sleeping body's velocities or positions.
    pub fn wake(&mut self) {
        self.asleep = false;
        self.still.clear();
    }

    /// Wakes the body as still since `still` seconds, from where it is: it counts as
    /// settled (`world::sleep`) until it moves, so that waking it does not wake the
    /// sleeping bodies it touches.
    pub(crate) fn wake_still(&mut self, still: f32) {
        self.asleep = false;
        let (p, carry) = (&self.phyxels.pos, &self.phyxels.pos_carry);
        self.still.restart(
            (0..self.phyxels.len()).map(|j| (p.get(j), carry.get(j))),
            still,
        );
    }

    /// Puts the body to sleep at rest: velocities and pending forces zero.
    pub(crate) fn fall_asleep(&mut self) {
        self.asleep = true;
        self.still.clear();
        self.phyxels.vel.fill_zero();
        self.phyxels.force.fill_zero();
    }

    /// True for objects whose motion is prescribed ([`Dynamics::is_prescribed`]: static
    /// objects and tools).
    pub fn is_prescribed(&self) -> bool {
        self.dynamics.is_prescribed()
    }

    /// True when the backend joins the implicit solve ([`Dynamics::implicit`] gives its
    /// operators), as read at [`Object::new`], [`Object::set_dynamics`] and the start of
    /// each step.
    pub fn is_implicit(&self) -> bool {
        self.implicit
    }

    /// Reads anew whether the backend joins the implicit solve.
    pub fn refresh_implicit(&mut self) {
        self.implicit = self.dynamics.implicit().is_some();
    }

    /// Replaces the backend.
    pub fn set_dynamics(&mut self, dynamics: Box<dyn Dynamics>) {
        self.dynamics = dynamics;
        self.refresh_implicit();
    }

    /// True if this object's contacts may be springs in an implicit solve: it is implicit
    /// or its motion is prescribed (static, a tool).
    pub fn may_join_solve(&self) -> bool {
        self.is_prescribed() || self.is_implicit()
    }

    /// True if the contact between this object and `other` joins an implicit solve as
    /// springs: both [`Object::may_join_solve`], and one is implicit.
    pub fn contact_in_solve(&self, other: &Object) -> bool {
        self.may_join_solve()
            && other.may_join_solve()
            && !(self.is_prescribed() && other.is_prescribed())
    }

    /// Moves the surfels with the phyxels (uses the backend's gradient, or the core's
    /// MLS estimate when the backend has none). Returns the surfels moved.
    pub fn advect_surfels(&mut self) -> usize {
        self.with_gradient(|binding, surfels, phyxels, grad| {
            binding.advect(surfels, phyxels, grad);
        });
        self.surfels.len()
    }

    /// Tabulates this step's surfel field from the phyxels without moving the surfels
    /// ([`SurfelBinding::prepare`]): every block is stale until
    /// [`Object::advect_outline`], [`Object::advect_surfels_in`] or
    /// [`Object::sync_surfels`] moves it.
    pub fn prepare_surfels(&mut self) {
        self.with_gradient(|binding, _, phyxels, grad| binding.prepare(phyxels, grad));
    }

    /// Calls `f` with the binding, the surfels, the phyxels and the displacement
    /// gradient of every phyxel: the backend's, or the core's MLS estimate when the
    /// backend has none.
    fn with_gradient(
        &mut self,
        f: impl FnOnce(&mut SurfelBinding, &mut Surfels, &Phyxels, &[Mat3]),
    ) {
        let grad: &[Mat3] = match self.dynamics.displacement_gradient() {
            Some(g) => {
                assert_eq!(
                    g.len(),
                    self.phyxels.len(),
                    "object '{}': backend '{}' gave a displacement gradient per phyxel of the \
                     wrong length",
                    self.name,
                    self.dynamics.name()
                );
                g
            }
            None => {
                let (stencil, grad) = self.estimate.get_or_insert_with(|| {
                    (
                        MlsStencil::build(&self.phyxels),
                        vec![Mat3::ZERO; self.phyxels.len()],
                    )
                });
                stencil.displacement_gradients(&self.phyxels.pos, &self.phyxels.rest, grad);
                grad
            }
        };
        f(&mut self.binding, &mut self.surfels, &self.phyxels, grad);
    }

    /// After [`Object::prepare_surfels`]: advects the blocks that can reach the edge of
    /// the object's box, so that the union of the block boxes is the surfels' exact box
    /// (the broad phase's) while most of a large body stays stale: the outermost block
    /// on each side, then, until none is left, the stale blocks whose bound pokes out of
    /// the box of the advected ones.
    pub fn advect_outline(&mut self) -> usize {
        let boxes = self.binding.block_boxes();
        if boxes.is_empty() {
            return 0;
        }
        // Seeds: on each side, the block whose bound reaches furthest.
        let mut seeds = [0usize; 6];
        for (side, seed) in seeds.iter_mut().enumerate() {
            let reach = |b: &Aabb| {
                let (axis, low) = (side % 3, side >= 3);
                if low { -b.min[axis] } else { b.max[axis] }
            };
            *seed = (0..boxes.len())
                .max_by(|&a, &b| reach(&boxes[a]).total_cmp(&reach(&boxes[b])))
                .unwrap_or(0);
        }
        let mut moved = self.binding.advect_blocks(&mut self.surfels, |k, b| {
            seeds.contains(&k) || b.is_non_finite()
        });
        loop {
            let exact = self.binding.current_box();
            let pokes_out = |_: usize, b: &Aabb| {
                b.is_non_finite() || b.min.cmplt(exact.min).any() || b.max.cmpgt(exact.max).any()
            };
            let more = match exact.is_non_finite() {
                true => 0,
                false => self.binding.advect_blocks(&mut self.surfels, pokes_out),
            };
            if more == 0 {
                return moved;
            }
            moved += more;
        }
    }

    /// Advects the stale blocks whose box meets `region` (or is non-finite): the
    /// surfels there are then where the phyxels put them this step. Returns the
    /// surfels moved.
    pub fn advect_surfels_in(&mut self, region: &Aabb) -> usize {
        self.binding.advect_blocks(&mut self.surfels, |_, b| {
            b.is_non_finite() || b.intersection(region).is_some()
        })
    }

    /// Advects every stale block: afterwards all surfels follow the phyxels. Returns the
    /// surfels moved.
    pub fn sync_surfels(&mut self) -> usize {
        self.binding.advect_blocks(&mut self.surfels, |_, _| true)
    }

    /// Moves the output mesh's vertices with the phyxels (only when a mesh frame is
    /// written: the field of the last step, as the surfels'). Static objects' meshes
    /// stay where they were built.
    pub fn follow_mesh(&mut self) {
        if self.is_static() {
            return;
        }
        let Some(mut mesh) = self.mesh.take() else {
            return;
        };
        self.with_gradient(|_, _, phyxels, grad| mesh.follow(phyxels, grad));
        self.mesh = Some(mesh);
    }

    /// The displacement gradient per phyxel (column b = ∂u/∂x_b) of the last step:
    /// the backend's, or the core's MLS estimate that the step's advection made; `None`
    /// before a first step of a backend without one (and for static objects).
    pub fn displacement_gradient(&self) -> Option<&[Mat3]> {
        self.dynamics
            .displacement_gradient()
            .or(self.estimate.as_ref().map(|e| &e.1[..]))
            .filter(|g| g.len() == self.phyxels.len())
    }

    /// True when every surfel is where the last advection table puts it (no block left
    /// stale by [`Object::prepare_surfels`]).
    pub fn surfels_current(&self) -> bool {
        self.binding.is_current()
    }
}
