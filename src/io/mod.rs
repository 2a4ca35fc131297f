//! Frames in and out: the render surface as plain columns with its PLY and VTP writers,
//! the PLY reader (frames, meshes, point clouds), and the frames of a [`crate::World`].

pub mod frame;
pub mod import;
pub mod output;
