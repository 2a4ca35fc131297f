//! Hostile input: property-based fuzzing of scene files (corpus and kept crashes under
//! tests/fuzz/), random scenes soaked with tools, the hostile-input cases.
//! References and tolerances: docs/ACCURACY.md.

#[path = "../common/mod.rs"]
mod common;

mod fuzz;
mod issue_51_hostile_input;
mod soak;
