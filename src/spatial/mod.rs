//! Spatial queries: the uniform hash grid, the Morton storage order, the broad phase's
//! boxes and pairs, and row gathers without bounds checks for the lane kernels.

pub mod broad_phase;
pub mod gather;
pub mod grid;
pub mod morton;
