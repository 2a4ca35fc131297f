//! Files in and out, below the engine: a frame of the render surface as plain columns,
//! the PLY and VTP writers of point tables, output files written whole or not at all, the PLY reader (frames, meshes, point
//! clouds), a run's USD stage, and the exact-length arrays of scene files. The frames of a
//! [`crate::World`] are [`crate::world::output`].

pub mod arrays;
pub mod atomic;
pub mod frame;
pub mod import;
pub mod points;
pub mod usd;

/// Largest scene file read (bytes): a scene is a page of TOML; a 50 MB file of 1.3
/// million `fixed` entries takes 4.1 GB to parse.
pub const SCENE_FILE_LIMIT: u64 = 16 << 20;
/// Largest mesh or frame file read (bytes): a 2-million-triangle binary PLY is 37 MB.
pub const INPUT_FILE_LIMIT: u64 = 1 << 30;

/// Checks, before opening it, that `path` is a regular file (links followed) of at most
/// `limit` bytes: a FIFO would block the open, a device such as `/dev/zero` never ends,
/// and a file is read whole. The message names neither the path nor the caller's
/// option; the caller prefixes them.
pub fn check_input_file(path: &std::path::Path, limit: u64) -> Result<(), String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("cannot open: {e}"))?;
    if meta.is_dir() {
        return Err("a directory, not a file".to_string());
    }
    if !meta.is_file() {
        return Err("not a regular file (a device, FIFO or socket): give a file".to_string());
    }
    if meta.len() > limit {
        return Err(format!(
            "{} bytes, more than the limit of {limit} bytes for this kind of file",
            meta.len()
        ));
    }
    Ok(())
}
