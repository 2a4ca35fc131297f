//! The contact pipeline: detection against the surface field, the contact surface and its
//! resampling, forces and their output, concave and thin bodies, Hertz on a plane, pairs in
//! order.
//! References and tolerances: docs/ACCURACY.md.

#[path = "../common/mod.rs"]
mod common;

mod concave;
mod contact;
mod contact_output;
mod detect;
mod hertz;
mod pairs_in_order;
mod resample;
