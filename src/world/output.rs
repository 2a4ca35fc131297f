//! The frames of a [`World`]: its render surface and phyxels as [`Frame`]s, written as
//! binary PLY or VTK XML PolyData.

use crate::contact::ContactSurfel;
use crate::io::frame::{Format, Frame};
use crate::world::World;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `surfels_NNNNN.ply` (and `phyxels_NNNNN.ply` when asked) for frame `frame`
/// into `dir`. Surfel properties: position, normal, radius, object id, contact flag.
pub fn write_frame(world: &World, dir: &Path, frame: u64, phyxels: bool) -> std::io::Result<()> {
    write_frame_as(world, dir, frame, phyxels, Format::Ply).map(|_| ())
}

/// Like [`write_frame`] with the surfel file in `format` (`surfels_NNNNN.ply` or
/// `.vtp`); returns the render surface that was written.
pub fn write_frame_as(
    world: &World,
    dir: &Path,
    frame: u64,
    phyxels: bool,
    format: Format,
) -> std::io::Result<Frame> {
    std::fs::create_dir_all(dir)?;
    let surface = surface_frame(world);
    surface.write(
        &dir.join(format!("surfels_{frame:05}.{}", format.extension())),
        format,
    )?;
    if phyxels {
        write_phyxels(world, &dir.join(format!("phyxels_{frame:05}.ply")))?;
    }
    Ok(surface)
}

fn create(path: &Path) -> std::io::Result<BufWriter<File>> {
    File::create(path)
        .map(BufWriter::new)
        .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display())))
}

/// The render surface `S' = S \ C ∪ Φ` (paper §8) of every object as one point cloud:
/// each object's surfels except its colliding ones, plus the resampled contact surfels
/// (flag `contact = 1`, disk radius from their object's surfel spacing). It needs
/// `World::render_contacts` set before the step: otherwise Φ is not resampled and only
/// the force carriers among the colliding surfels are known.
pub fn surface_frame(world: &World) -> Frame {
    let n_obj = world.objects.len();
    let mut colliding: Vec<Vec<bool>> = world
        .objects
        .iter()
        .map(|o| vec![false; o.surfels.len()])
        .collect();
    for d in &world.detections {
        for c in &d.a_in_b {
            colliding[d.a][c.surfel as usize] = true;
        }
        for c in &d.b_in_a {
            colliding[d.b][c.surfel as usize] = true;
        }
    }
    let mut frame = Frame::default();
    for (k, o) in world.objects.iter().enumerate() {
        let s = &o.surfels;
        for i in (0..s.len()).filter(|&i| !colliding[k][i]) {
            frame.push(s.pos.get(i), s.normal.get(i), s.radius[i], o.id as i32, 0);
        }
    }
    for c in world.patches.iter().flat_map(|p| &p.render) {
        let c: &ContactSurfel = c;
        let o = &world.objects[c.object.min(n_obj - 1)];
        let r = o.surfel_spacing * std::f32::consts::FRAC_2_PI.sqrt();
        frame.push(c.pos, c.normal, r, o.id as i32, 1);
    }
    frame
}

/// The render surface of every object (see [`surface_frame`]) as one binary PLY file.
pub fn write_surfels(world: &World, path: &Path) -> std::io::Result<PathBuf> {
    surface_frame(world).write_ply(path)?;
    Ok(path.to_path_buf())
}

/// All phyxels of the world as one PLY point cloud.
pub fn write_phyxels(world: &World, path: &Path) -> std::io::Result<PathBuf> {
    let n: usize = world.objects.iter().map(|o| o.phyxels.len()).sum();
    let mut w = create(path)?;
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment phyxel phyxels\nelement vertex {n}\n\
         property float x\nproperty float y\nproperty float z\n\
         property float vx\nproperty float vy\nproperty float vz\n\
         property float mass\nproperty float radius\nproperty int object\nend_header\n"
    )?;
    for o in &world.objects {
        let p = &o.phyxels;
        for i in 0..p.len() {
            let x = p.pos.get(i);
            let v = p.vel.get(i);
            for f in [x.x, x.y, x.z, v.x, v.y, v.z, p.mass[i], p.radius[i]] {
                w.write_all(&f.to_le_bytes())?;
            }
            w.write_all(&(o.id as i32).to_le_bytes())?;
        }
    }
    w.flush()?;
    Ok(path.to_path_buf())
}
