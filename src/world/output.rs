//! The frames of a [`World`]: its render surface and phyxels as [`Frame`]s, written as
//! binary PLY or VTK XML PolyData.

use crate::contact::{ContactPoint, ContactSurfel};
use crate::io::frame::{Format, Frame};
use crate::io::points::{Column, Points, Values};
use crate::world::World;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// Writes `surfels_NNNNN.ply`, `contacts_NNNNN.ply` (the [`ContactFrame`]) and, when
/// asked, `phyxels_NNNNN.ply` for frame `frame` into `dir`. Surfel properties: position,
/// normal, radius, object id, contact flag.
pub fn write_frame(world: &World, dir: &Path, frame: u64, phyxels: bool) -> std::io::Result<()> {
    write_frame_as(world, dir, frame, phyxels, Format::Ply).map(|_| ())
}

/// Like [`write_frame`] with the surfel and contact files in `format` (`.ply` or
/// `.vtp`); returns the render surface that was written.
pub fn write_frame_as(
    world: &World,
    dir: &Path,
    frame: u64,
    phyxels: bool,
    format: Format,
) -> std::io::Result<Frame> {
    std::fs::create_dir_all(dir)?;
    let files = frame_files(frame, phyxels, format);
    let surface = surface_frame(world);
    surface.write(&dir.join(&files[0]), format)?;
    contact_frame(world).write(&dir.join(&files[1]), format)?;
    if phyxels {
        write_phyxels(world, &dir.join(&files[2]))?;
    }
    Ok(surface)
}

/// The names of the files [`write_frame_as`] writes for frame `frame`: the surfels, the
/// contacts, then the phyxels when asked.
pub fn frame_files(frame: u64, phyxels: bool, format: Format) -> Vec<String> {
    let ext = format.extension();
    let mut files = vec![
        format!("surfels_{frame:05}.{ext}"),
        format!("contacts_{frame:05}.{ext}"),
    ];
    if phyxels {
        files.push(format!("phyxels_{frame:05}.ply"));
    }
    files
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
    for d in &world.contact.detections {
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
    for c in world.contact.patches.iter().flat_map(|p| &p.render) {
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

/// All phyxels of the world as one PLY point cloud: position, velocity, mass, radius,
/// object id.
pub fn write_phyxels(world: &World, path: &Path) -> std::io::Result<PathBuf> {
    let (mut pos, mut vel, mut mass, mut radius, mut object) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for o in &world.objects {
        let p = &o.phyxels;
        pos.extend((0..p.len()).map(|i| p.pos.get(i)));
        vel.extend((0..p.len()).map(|i| p.vel.get(i)));
        // The scalar columns are padded for the SIMD loops: only the first `len` count.
        mass.extend_from_slice(&p.mass[..p.len()]);
        radius.extend_from_slice(&p.radius[..p.len()]);
        object.extend((0..p.len()).map(|_| o.id as i32));
    }
    let columns = [
        Column {
            ply: &["vx", "vy", "vz"],
            vtk: "velocity",
            values: Values::Vec3(&vel),
        },
        Column {
            ply: &["mass"],
            vtk: "mass",
            values: Values::F32(&mass),
        },
        Column {
            ply: &["radius"],
            vtk: "radius",
            values: Values::F32(&radius),
        },
        Column {
            ply: &["object"],
            vtk: "object",
            values: Values::I32(&object),
        },
    ];
    let points = Points {
        pos: &pos,
        columns: &columns,
    };
    points.write_ply(path, "phyxel phyxels")?;
    Ok(path.to_path_buf())
}

/// The contact surfels of every pair that carry force at the last contact phase
/// ([`ContactState::patches`](crate::world::ContactState::patches)), one point each with the columns of
/// [`crate::contact::ContactPoint`] and the pair's object ids `a` and `b`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContactFrame {
    pub pos: Vec<Vec3>,
    pub normal: Vec<Vec3>,
    pub area: Vec<f32>,
    pub penetration: Vec<f32>,
    pub penalty_force: Vec<Vec3>,
    pub friction_force: Vec<Vec3>,
    pub slip_velocity: Vec<Vec3>,
    pub a: Vec<i32>,
    pub b: Vec<i32>,
}

/// The contact frame of `world` (see [`ContactFrame`]).
pub fn contact_frame(world: &World) -> ContactFrame {
    let mut f = ContactFrame::default();
    for patch in &world.contact.patches {
        let (a, b) = (world.objects[patch.a].id, world.objects[patch.b].id);
        for c in &patch.surfels {
            let p = ContactPoint::of(c);
            f.pos.push(Vec3::from(p.position));
            f.normal.push(Vec3::from(p.normal));
            f.area.push(p.area);
            f.penetration.push(p.penetration);
            f.penalty_force.push(Vec3::from(p.penalty_force));
            f.friction_force.push(Vec3::from(p.friction_force));
            f.slip_velocity.push(Vec3::from(p.slip_velocity));
            f.a.push(a as i32);
            f.b.push(b as i32);
        }
    }
    f
}

impl ContactFrame {
    /// Writes the frame to `path` in `format` (PLY properties `x y z nx ny nz area
    /// penetration penalty_force_{x,y,z} friction_force_{x,y,z} slip_velocity_{x,y,z} a
    /// b`; VTK arrays of the same names, vectors as three components).
    pub fn write(&self, path: &Path, format: Format) -> std::io::Result<()> {
        let columns = [
            Column::normals(&self.normal),
            Column {
                ply: &["area"],
                vtk: "area",
                values: Values::F32(&self.area),
            },
            Column {
                ply: &["penetration"],
                vtk: "penetration",
                values: Values::F32(&self.penetration),
            },
            Column {
                ply: &["penalty_force_x", "penalty_force_y", "penalty_force_z"],
                vtk: "penalty_force",
                values: Values::Vec3(&self.penalty_force),
            },
            Column {
                ply: &["friction_force_x", "friction_force_y", "friction_force_z"],
                vtk: "friction_force",
                values: Values::Vec3(&self.friction_force),
            },
            Column {
                ply: &["slip_velocity_x", "slip_velocity_y", "slip_velocity_z"],
                vtk: "slip_velocity",
                values: Values::Vec3(&self.slip_velocity),
            },
            Column {
                ply: &["a"],
                vtk: "a",
                values: Values::I32(&self.a),
            },
            Column {
                ply: &["b"],
                vtk: "b",
                values: Values::I32(&self.b),
            },
        ];
        let points = Points {
            pos: &self.pos,
            columns: &columns,
        };
        match format {
            Format::Ply => points.write_ply(path, "phyxel contact surfels"),
            Format::Vtk => points.write_vtp(path),
        }
    }
}
