//! The bottom layer: numerics every other module may use and none owns — small dense
//! linear algebra, the smoothing kernels, and Brent's root finder. It imports nothing
//! from the rest of the crate.

pub mod brent;
pub mod kernel;
pub mod linalg;
