//! # phyxel
//!
//! Interactive contact handling for deformable point-based objects, after Keiser et al.
//! 2004 ("Contact handling for deformable point-based objects"), on top of the MLS
//! point-based animation of Müller et al. 2004.
//!
//! Objects are point clouds: **surfels** sample the surface, **phyxels** the volume.
//! A pluggable [`Dynamics`] backend moves the phyxels; the surfels
//! follow them; the contact pipeline then finds, resolves and responds to contacts.
//!
//! ```no_run
//! use phyxel::scene::Scene;
//! let scene = Scene::builtin("two-spheres").unwrap();
//! let mut world = scene.build(&Default::default()).unwrap();
//! for _ in 0..100 {
//!     world.step();
//! }
//! println!("momentum {:?}", world.momentum());
//! ```
//!
//! ## The paper, step by step
//!
//! | step (Keiser et al. 2004 unless noted) | module |
//! |---|---|
//! | object `Γ = (S, P)`: surfels, phyxels, SoA columns (§3) | [`body::object`], [`points::surfels`], [`points::phyxels`], [`columns`] |
//! | sampling shapes and meshes | [`body::shape`], [`body::mesh`], [`scene`] |
//! | dynamics of the phyxels (Müller et al. 2004; pluggable) | [`dynamics`] ([`Dynamics`]), `backends/` ([`backends`]) |
//! | MLS displacement gradient (Müller et al. 2004, §4.2) | [`dynamics::mls`], [`math::kernel`] |
//! | surfels follow the phyxels (Müller et al. 2004, §5) | [`body::advect`] |
//! | the step, `animate` (§8), its phases and guards | [`world`], [`world::phase`] |
//! | broad phase: object boxes and pairs (§5) | [`spatial::broad_phase`] |
//! | spatial hashing (Teschner et al. 2003) | [`spatial::grid`], [`spatial::morton`] |
//! | implicit surface of a surfel set (§5, eq. 1) | [`contact::implicit`] |
//! | colliding surfels (§5, eq. 2) | [`contact::detect`] |
//! | contact surface Φ (§6) and its resampling | [`contact::contact_surface`], [`contact::resample`] |
//! | penalty and friction forces (§7) | [`contact::forces`], [`contact::params`] |
//! | distribution to the phyxels (§7, eqs. 8–9) | [`contact::distribute`] |
//! | fracture and self-collision (§4, §8) | [`body::fracture`], [`body::connectivity`], [`body::self_collision`] |
//!
//! Around the engine: [`scene`] (the TOML format, checks, building a [`World`]), [`io`]
//! (frames in and out), and, with the `app` feature, [`app`] (the run loop and its
//! summary, the validation suite, the renderer) that the `phyxel` command line uses.

// Lets the backends under `backends/` name the engine `phyxel::...` exactly as an
// outside crate would.
extern crate self as phyxel;

pub mod body;
pub mod columns;
pub mod conformance;
pub mod contact;
pub mod dynamics;
pub mod io;
pub mod material;
pub mod math;
pub mod points;
pub mod scene;
pub mod solver;
pub mod spatial;
pub mod world;

#[cfg(feature = "app")]
pub mod app;

#[cfg(feature = "python")]
mod python;

#[cfg(feature = "app")]
#[doc(hidden)]
pub use app::{render, summary, validate};
/// Fracture and self-collision, one flat module in phyxel 0.1.
#[doc(hidden)]
pub mod topology {
    pub use crate::body::fracture::*;
    pub use crate::body::self_collision::*;
}
/// The flat module paths of phyxel 0.1 (before the folders by concept), kept so that
/// code written against them compiles; new code uses the folders.
#[doc(hidden)]
pub use {
    body::{advect, connectivity, mesh, object, shape},
    contact::{detect, implicit},
    dynamics::mls,
    io::{frame, import},
    math::{brent, kernel},
    points::{phyxels, surfels},
    spatial::{broad_phase, gather, grid, morton},
    world::{output, phase as timing},
};

#[doc(hidden)]
#[path = "../backends/mls/mod.rs"]
pub mod mls_backend;

#[doc(hidden)]
#[path = "../backends/sph/mod.rs"]
pub mod sph_backend;

#[doc(hidden)]
#[path = "../backends/lj/mod.rs"]
pub mod lj_backend;

/// The built-in dynamics backends, each stored under `backends/` and written only
/// against the public API above.
pub mod backends {
    pub use super::lj_backend as lj;
    pub use super::mls_backend as mls;
    pub use super::sph_backend as sph;

    use crate::dynamics::kinematic::Kinematic;
    use crate::dynamics::{Dynamics, StaticDynamics};
    use crate::material::Material;
    use crate::points::phyxels::Phyxels;

    /// The prescribed-motion backend (`backend = "kinematic"`): a rigid body the caller
    /// moves, such as a tool ([`crate::dynamics::kinematic`]). Not in [`NAMES`]: it is no
    /// dynamics to compare, and `--backend` leaves such objects as they are.
    pub const KINEMATIC: &str = crate::dynamics::kinematic::NAME;

    /// Names accepted by `backend = "..."` in scenes and `--backend`.
    pub const NAMES: &[&str] = &[mls::NAME, mls::implicit::NAME, sph::NAME, lj::NAME];

    /// The backends that model plastic flow (`plastic_yield`, `plastic_creep`,
    /// `plastic_max`); the others treat a plastic material as elastic.
    pub const PLASTIC: &[&str] = &[mls::NAME, mls::implicit::NAME];

    /// Creates backend `name` for `phyxels`, or explains which names exist.
    pub fn create(
        name: &str,
        phyxels: &Phyxels,
        material: &Material,
    ) -> Result<Box<dyn Dynamics>, String> {
        match name {
            mls::NAME => Ok(Box::new(mls::MlsDynamics::new(phyxels, material))),
            mls::implicit::NAME => Ok(Box::new(mls::MlsImplicit::new(phyxels, material))),
            sph::NAME => Ok(Box::new(sph::SphDynamics::new(phyxels, material))),
            lj::NAME => Ok(Box::new(lj::LjDynamics::new(phyxels, material))),
            "static" => Ok(Box::new(StaticDynamics)),
            KINEMATIC => Ok(Box::new(Kinematic::new(phyxels))),
            other => Err(format!(
                "unknown backend '{other}' (available: {})",
                NAMES.join(", ")
            )),
        }
    }
}

/// The README's code blocks as doctests (its library example is compiled and run), so
/// that the README stays true.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// The vector types of the API (`Vec3`, `Mat3`, `Quat`), at the version phyxel uses.
pub use glam;

pub use body::object::Object;
pub use dynamics::{Dynamics, StepContext};
pub use material::Material;
pub use points::phyxels::Phyxels;
pub use points::surfels::Surfels;
pub use world::World;
