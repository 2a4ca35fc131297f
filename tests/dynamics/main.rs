//! The dynamics backends: the conformance suite over the registry, MLS elasticity, the
//! implicit solve, the kinematic tool, plasticity, the cantilever, free fall.
//! References and tolerances: docs/ACCURACY.md.

#[path = "../common/mod.rs"]
mod common;

mod backends;
mod cantilever;
mod free_fall;
mod implicit;
mod kinematic;
mod mls;
mod plasticity;
mod stabilisation;
