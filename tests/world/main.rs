//! The world and its step: results independent of the thread count, a droppable cache, work
//! only for what a scene uses.
//! References and tolerances: docs/ACCURACY.md.

#[path = "../common/mod.rs"]
mod common;

mod lazy;
mod model_only_what_needed;
mod sleep;
mod threads;
mod world_cache;
