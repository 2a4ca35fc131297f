//! An object and what happens to it: surfel advection, meshes and point clouds read,
//! fracture and self-collision.
//! References and tolerances: docs/ACCURACY.md.

#[path = "../common/mod.rs"]
mod common;

mod advect;
mod import;
mod mesh;
mod topology;
