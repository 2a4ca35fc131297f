//! Frame output: binary little-endian PLY files of surfels and phyxels.

use crate::contact::ContactSurfel;
use crate::world::World;
use glam::Vec3;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Writes `surfels_NNNNN.ply` (and `phyxels_NNNNN.ply` when asked) for frame `frame`
/// into `dir`. Surfel properties: position, normal, radius, object id, contact flag.
pub fn write_frame(world: &World, dir: &Path, frame: u64, phyxels: bool) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    write_surfels(world, &dir.join(format!("surfels_{frame:05}.ply")))?;
    if phyxels {
        write_phyxels(world, &dir.join(format!("phyxels_{frame:05}.ply")))?;
    }
    Ok(())
}

fn create(path: &Path) -> std::io::Result<BufWriter<File>> {
    File::create(path)
        .map(BufWriter::new)
        .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display())))
}

/// The render surface `S' = S \ C ∪ Φ` (paper §8) of every object as one PLY point
/// cloud: each object's surfels except its colliding ones, plus the resampled contact
/// surfels (flag `contact = 1`, disk radius from their object's surfel spacing).
pub fn write_surfels(world: &World, path: &Path) -> std::io::Result<PathBuf> {
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
    let contact: Vec<&ContactSurfel> = world.patches.iter().flat_map(|p| &p.render).collect();
    let kept: usize = colliding
        .iter()
        .map(|c| c.iter().filter(|&&x| !x).count())
        .sum();
    let n = kept + contact.len();
    let mut w = create(path)?;
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment phyxel render surface\nelement vertex {n}\n\
         property float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property float radius\nproperty int object\nproperty uchar contact\nend_header\n"
    )?;
    let vertex = |w: &mut BufWriter<File>, p: Vec3, nrm: Vec3, r: f32, id: u32, flag: u8| {
        for v in [p.x, p.y, p.z, nrm.x, nrm.y, nrm.z, r] {
            w.write_all(&v.to_le_bytes())?;
        }
        w.write_all(&(id as i32).to_le_bytes())?;
        w.write_all(&[flag])
    };
    for (k, o) in world.objects.iter().enumerate() {
        let s = &o.surfels;
        for i in (0..s.len()).filter(|&i| !colliding[k][i]) {
            vertex(&mut w, s.pos.get(i), s.normal.get(i), s.radius[i], o.id, 0)?;
        }
    }
    for c in contact {
        let o = &world.objects[c.object.min(n_obj - 1)];
        let r = o.surfel_spacing * std::f32::consts::FRAC_2_PI.sqrt();
        vertex(&mut w, c.pos, c.normal, r, o.id, 1)?;
    }
    w.flush()?;
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
