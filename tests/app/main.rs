//! The application layer: the software renderer and the validation suite.
//! References and tolerances: docs/ACCURACY.md.

#[path = "../common/mod.rs"]
mod common;

mod hint;
mod render;
mod validate;
