//! A run's output folder (`run --out DIR`): which files are frames, the refusal of a
//! folder that holds another run's frames (a shorter run would leave the longer run's
//! later frames beside its own), the clearing of them when overwriting, and the
//! manifest that lists what the run wrote.

use crate::io::frame::Format;
use serde::Serialize;
use std::path::Path;

/// The manifest's file name in the output folder (prefixed: a folder's own
/// `manifest.json` is no run's).
pub const MANIFEST: &str = "phyxel-manifest.json";

/// Whether `name` is a file a run writes into its folder: a frame
/// (`surfels_N.ply|vtp|png`, `contacts_N.ply|vtp`, `phyxels_N.ply|vtp`,
/// `mesh_N.ply|vtp`, N of five or more digits), the manifest, or one of these being written when a run was killed
/// (`.NAME.PID-N.tmp`, [`crate::io::atomic`]).
pub fn is_run_file(name: &str) -> bool {
    if name == MANIFEST || name == COLLECTION || name == STAGE {
        return true;
    }
    if let Some(inner) = name.strip_prefix('.').and_then(|n| n.strip_suffix(".tmp"))
        && let Some((file, tag)) = inner.rsplit_once('.')
        && let Some((pid, n)) = tag.split_once('-')
        && [pid, n]
            .iter()
            .all(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
    {
        return is_run_file(file);
    }
    let Some((stem, ext)) = name.rsplit_once('.') else {
        return false;
    };
    let Some((kind, number)) = stem.split_once('_') else {
        return false;
    };
    let exts: &[&str] = match kind {
        "surfels" => &["ply", "vtp", "png"],
        "contacts" | "phyxels" | "mesh" => &["ply", "vtp"],
        _ => return false,
    };
    number.len() >= 5 && number.bytes().all(|b| b.is_ascii_digit()) && exts.contains(&ext)
}

/// Makes `dir` ready for a run: creates it, and checks it holds no files of another
/// run ([`is_run_file`]). With `overwrite` those are removed (a link itself, never
/// what it points to); without, they are an error that names one and how to go on.
/// Other files are left alone.
pub fn prepare(dir: &Path, overwrite: bool) -> Result<(), String> {
    make_dir(dir)?;
    let mut found: Vec<String> = std::fs::read_dir(dir)
        .map_err(|e| format!("cannot read the directory: {e}"))?
        .filter_map(|e| e.ok())
        .filter_map(|e| e.file_name().into_string().ok())
        .filter(|n| is_run_file(n))
        .collect();
    if found.is_empty() {
        return Ok(());
    }
    found.sort();
    if !overwrite {
        let (n, more) = (found.len(), if found.len() > 1 { ", …" } else { "" });
        let files = if n == 1 { "file" } else { "files" };
        return Err(format!(
            "holds {n} {files} of another run ({}{more}): give an empty or new folder, or \
             --overwrite to remove them first",
            found[0]
        ));
    }
    for name in &found {
        // remove_file removes a link, not its target.
        std::fs::remove_file(dir.join(name)).map_err(|e| format!("cannot remove {name}: {e}"))?;
    }
    Ok(())
}

/// Checks an output file of a run beside its frames (`--contacts`, `--flamegraph`)
/// before anything is written: it may not be a directory or a special file
/// ([`crate::io::atomic::check_output`]), the same file as one of `inputs` (the scene
/// file, its meshes), the same as another of the run's outputs (`others`), or a name
/// inside the frames' folder `out` that the run writes or `--overwrite` removes
/// ([`is_run_file`]), or that folder itself. The message names no option; the caller
/// prefixes it.
pub fn check_side_output(
    path: &Path,
    out: Option<&Path>,
    inputs: &[&Path],
    others: &[&Path],
) -> Result<(), String> {
    crate::io::atomic::check_output(path)?;
    if let Some(input) = inputs.iter().find(|i| same_file(path, i)) {
        return Err(format!(
            "is the input {}: give another path for the output",
            input.display()
        ));
    }
    if let Some(other) = others.iter().find(|o| same_file(path, o)) {
        return Err(format!(
            "is also the output {}: give each output its own path",
            other.display()
        ));
    }
    if let Some(out) = out {
        if same_file(path, out) {
            return Err("is the --out folder: give a file path".to_string());
        }
        let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if same_file(parent.unwrap_or(Path::new(".")), out) && is_run_file(name) {
            return Err(format!(
                "is a frame or manifest name inside the --out folder {} (the run writes \
                 or removes it): give a path outside it or another name",
                out.display()
            ));
        }
    }
    Ok(())
}

/// Whether `a` and `b` name one file: both exist and canonicalise alike, or neither
/// exists and their parents do with the same file name.
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        (Err(_), Err(_)) => {
            let parent = |p: &Path| {
                let d = p.parent().filter(|d| !d.as_os_str().is_empty());
                std::fs::canonicalize(d.unwrap_or(Path::new("."))).ok()
            };
            a.file_name() == b.file_name() && parent(a).is_some() && parent(a) == parent(b)
        }
        _ => false,
    }
}

/// Creates the output directory `dir` (and its parents). A path that exists as a file
/// is said to be one: `create_dir_all` reports "File exists", which reads as if the
/// trouble were that something is there at all.
pub fn make_dir(dir: &Path) -> Result<(), String> {
    if dir.exists() && !dir.is_dir() {
        return Err("a file, not a directory: give a directory for the output".to_string());
    }
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create the directory: {e}"))
}

/// `phyxel-manifest.json`: what one run wrote into its folder.
#[derive(Serialize)]
pub struct Manifest<'a> {
    pub scene: &'a str,
    /// Steps run.
    pub steps: u64,
    /// Steps between frames (the last frame is the last step's, wherever it falls).
    pub every: u64,
    /// The time step at the run's end (s).
    pub dt: f32,
    /// The run was stopped (Ctrl-C) before its last step.
    pub interrupted: bool,
    /// The state stayed finite (false: the run stopped where it did not).
    pub finite: bool,
    /// The frames' file extension (`ply` or `vtp`).
    pub format: &'a str,
    /// What the surfel frames hold: `render` (the render surface, whose points change
    /// with the contact) or `fixed` (each body's own surfels in a fixed order,
    /// `run --fixed-points`).
    pub surfels: &'a str,
    /// Each frame's simulated time (s), by frame number.
    pub times: &'a [f64],
    /// Every file the run wrote, in order.
    pub frames: &'a [String],
}

/// The ParaView collection of a `--format vtk` run: every frame's `.vtp` files with
/// their simulated time, so that ParaView opens one file and plays the series in time.
pub const COLLECTION: &str = "frames.pvd";

/// The USD stage of a run written with `--format usd` ([`crate::io::usd`]).
pub const STAGE: &str = "frames.usda";

/// Writes [`COLLECTION`] into `dir`: frame k's surfels (part 0), contacts (part 1),
/// then, when written, phyxels and meshes (the next parts) at `times[k]` (s), whole or
/// not at all.
pub fn write_collection(
    dir: &Path,
    times: &[f64],
    phyxels: bool,
    mesh: bool,
) -> std::io::Result<()> {
    let mut text = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" \
         byte_order=\"LittleEndian\">\n<Collection>\n",
    );
    for (k, t) in times.iter().enumerate() {
        let mut files = crate::world::output::frame_files(k as u64, phyxels, Format::Vtk);
        if mesh {
            files.push(crate::world::output::mesh_file(k as u64, Format::Vtk));
        }
        for (part, file) in files.iter().enumerate() {
            text.push_str(&format!(
                "<DataSet timestep=\"{t:e}\" group=\"\" part=\"{part}\" file=\"{file}\"/>\n"
            ));
        }
    }
    text.push_str("</Collection>\n</VTKFile>\n");
    crate::io::atomic::write(&dir.join(COLLECTION), text.as_bytes())
}

/// Writes the manifest into `dir`, whole or not at all.
pub fn write_manifest(dir: &Path, manifest: &Manifest) -> std::io::Result<()> {
    let text = serde_json::to_string_pretty(manifest).map_err(std::io::Error::other)?;
    crate::io::atomic::write(&dir.join(MANIFEST), text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_files_are_recognised_and_others_are_not() {
        for name in [
            "surfels_00000.ply",
            "surfels_123456.vtp",
            "surfels_00001.png",
            "contacts_00003.vtp",
            "phyxels_00002.ply",
            "phyxels_00002.vtp",
            "mesh_00004.ply",
            "mesh_00004.vtp",
            "phyxel-manifest.json",
            "frames.pvd",
            "frames.usda",
            ".frames.usda.4242-3.tmp",
            ".surfels_00001.ply.4242-0.tmp",
        ] {
            assert!(is_run_file(name), "{name}");
        }
        for name in [
            "surfels_0001.ply",
            "phyxels_00002.png",
            "mesh_00001.png",
            "contacts_00001.png",
            "notes.txt",
            "surfels_0000a.ply",
            ".surfels_00001.ply.tmp",
            ".surfels_00001.ply.4242.tmp",
            ".notes.txt.42-1.tmp",
            "manifest.json",
            "scene.toml",
        ] {
            assert!(!is_run_file(name), "{name}");
        }
    }
}
