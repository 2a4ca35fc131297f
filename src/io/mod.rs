//! Files in and out, below the engine: a frame of the render surface as plain columns,
//! the PLY and VTP writers of point tables, the PLY reader (frames, meshes, point
//! clouds), and the exact-length arrays of scene files. The frames of a
//! [`crate::World`] are [`crate::world::output`].

pub mod arrays;
pub mod frame;
pub mod import;
pub mod points;
