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
//! | MLS displacement gradient (Müller et al. 2004, §4.2) | [`dynamics::gradient`], [`math::kernel`] |
//! | surfels follow the phyxels (Müller et al. 2004, §5) | [`body::advect`] |
//! | the step, `animate` (§8), its phases and guards | [`world`], [`world::phase`] |
//! | broad phase: object boxes and pairs (§5) | [`spatial::broad_phase`] |
//! | spatial hashing (Teschner et al. 2003) | [`spatial::grid`], [`spatial::morton`] |
//! | implicit surface of a surfel set (§5, eq. 1) | [`contact::field`] |
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
pub mod par;
pub mod points;
pub mod scene;
pub mod solver;
pub mod spatial;
#[doc(hidden)]
pub mod testing;
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

/// The built-in dynamics backends and their registry, stored under `backends/` and
/// written only against the public API.
#[path = "../backends/mod.rs"]
pub mod backends;

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
