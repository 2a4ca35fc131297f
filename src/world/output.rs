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
    write_frame_with(world, dir, frame, phyxels, format, Surface::Render)
}

/// Which points a surfel frame holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Surface {
    /// The render surface `S \ C ∪ Φ` ([`surface_frame`]): its points change with the
    /// contact.
    #[default]
    Render,
    /// Every object's own surfels in their stored order ([`fixed_frame`]): point i is
    /// the same material point in every frame (until an object fractures).
    Fixed,
}

/// Like [`write_frame_as`] with the surfel frame of `surface`; returns it.
pub fn write_frame_with(
    world: &World,
    dir: &Path,
    frame: u64,
    phyxels: bool,
    format: Format,
    surface: Surface,
) -> std::io::Result<Frame> {
    std::fs::create_dir_all(dir)?;
    let files = frame_files(frame, phyxels, format);
    let surface = match surface {
        Surface::Render => surface_frame(world),
        Surface::Fixed => fixed_frame(world),
    };
    surface.write(&dir.join(&files[0]), format)?;
    contact_frame(world).write(&dir.join(&files[1]), format)?;
    if phyxels {
        phyxel_frame(world).write(&dir.join(&files[2]), format)?;
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
        files.push(format!("phyxels_{frame:05}.{ext}"));
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
    let colliding = colliding_surfels(world);
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

/// Per object, per surfel: found colliding by the last detection.
fn colliding_surfels(world: &World) -> Vec<Vec<bool>> {
    let mut colliding: Vec<Vec<bool>> = world
        .objects
        .iter()
        .map(|o| vec![false; o.surfels.len()])
        .collect();
    for d in &world.contact.detections {
        for (k, list) in [(d.a, &d.a_in_b), (d.b, &d.b_in_a)] {
            for c in list {
                colliding[k][c.surfel as usize] = true;
            }
        }
    }
    colliding
}

/// Every object's own surfels, in object order and each object's stored order: a point
/// set of fixed size and order (Blender point caches and ParaView's per-point
/// displacement follow point i), colliding surfels flagged `contact = 1` in place
/// (with `World::render_contacts` every surfel is tested, else the force carriers).
pub fn fixed_frame(world: &World) -> Frame {
    let colliding = colliding_surfels(world);
    let mut frame = Frame::default();
    for (k, o) in world.objects.iter().enumerate() {
        let s = &o.surfels;
        for (i, &hit) in colliding[k].iter().enumerate() {
            let flag = u8::from(hit);
            frame.push(
                s.pos.get(i),
                s.normal.get(i),
                s.radius[i],
                o.id as i32,
                flag,
            );
        }
    }
    frame
}

/// The render surface of every object (see [`surface_frame`]) as one binary PLY file.
pub fn write_surfels(world: &World, path: &Path) -> std::io::Result<PathBuf> {
    surface_frame(world).write_ply(path)?;
    Ok(path.to_path_buf())
}

/// All phyxels of the world as one PLY point cloud ([`PhyxelFrame`]).
pub fn write_phyxels(world: &World, path: &Path) -> std::io::Result<PathBuf> {
    phyxel_frame(world).write(path, Format::Ply)?;
    Ok(path.to_path_buf())
}

/// Every phyxel of the world with its state and mechanics, in object order: position,
/// velocity, mass, radius, object id, displacement from rest, the Green–Lagrange strain
/// `E = ½(FᵀF − I)` of the last step's displacement gradient (`F = I + ∇u`) and the
/// Saint Venant–Kirchhoff stress `S = λ tr(E) I + 2μ E` of the object's material with
/// its von Mises value. Strain and stress are the total ones (a plastic body's plastic
/// part included) and zero for static objects and before a first step.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PhyxelFrame {
    pub pos: Vec<Vec3>,
    pub vel: Vec<Vec3>,
    pub mass: Vec<f32>,
    pub radius: Vec<f32>,
    pub object: Vec<i32>,
    /// `x − x₀` (m).
    pub displacement: Vec<Vec3>,
    /// `xx yy zz xy yz zx` (dimensionless; shear as tensor components, not engineering).
    pub strain: Vec<[f32; 6]>,
    /// `xx yy zz xy yz zx` (Pa).
    pub stress: Vec<[f32; 6]>,
    /// `√(½((s₁₁−s₂₂)² + (s₂₂−s₃₃)² + (s₃₃−s₁₁)²) + 3(s₁₂² + s₂₃² + s₃₁²))` (Pa).
    pub von_mises: Vec<f32>,
}

/// The phyxel frame of `world` (see [`PhyxelFrame`]).
pub fn phyxel_frame(world: &World) -> PhyxelFrame {
    let mut f = PhyxelFrame::default();
    for o in &world.objects {
        let p = &o.phyxels;
        let n = p.len();
        f.pos.extend((0..n).map(|i| p.pos.get(i)));
        f.vel.extend((0..n).map(|i| p.vel.get(i)));
        // The scalar columns are padded for the SIMD loops: only the first `len` count.
        f.mass.extend_from_slice(&p.mass[..n]);
        f.radius.extend_from_slice(&p.radius[..n]);
        f.object.extend((0..n).map(|_| o.id as i32));
        f.displacement
            .extend((0..n).map(|i| (p.pos.get(i) - p.rest.get(i)) + p.pos_carry.get(i)));
        let grad = o.displacement_gradient().filter(|_| !o.is_static());
        let (lambda, mu) = o.material.lame();
        for i in 0..n {
            let g = grad.map_or(glam::Mat3::ZERO, |g| g[i]);
            let j = glam::Mat3::IDENTITY + g;
            let e = (j.transpose() * j - glam::Mat3::IDENTITY) * 0.5;
            let tr = e.x_axis.x + e.y_axis.y + e.z_axis.z;
            let s = glam::Mat3::from_diagonal(Vec3::splat(lambda * tr)) + e * (2.0 * mu);
            let sym = |m: glam::Mat3| {
                [
                    m.x_axis.x, m.y_axis.y, m.z_axis.z, m.y_axis.x, m.z_axis.y, m.x_axis.z,
                ]
            };
            let [sxx, syy, szz, sxy, syz, szx] = sym(s);
            let vm = (0.5 * ((sxx - syy).powi(2) + (syy - szz).powi(2) + (szz - sxx).powi(2))
                + 3.0 * (sxy * sxy + syz * syz + szx * szx))
                .sqrt();
            f.strain.push(sym(e));
            f.stress.push(sym(s));
            f.von_mises.push(vm);
        }
    }
    f
}

impl PhyxelFrame {
    /// Writes the frame to `path` in `format`: PLY properties `x y z vx vy vz mass
    /// radius object ux uy uz` and `strain_xx`…`strain_zx`, `stress_xx`…`stress_zx`,
    /// `von_mises`; VTK arrays `velocity`, `mass`, `radius`, `object`, `displacement`,
    /// `strain` and `stress` (six-component symmetric tensors) and `von_mises`.
    pub fn write(&self, path: &Path, format: Format) -> std::io::Result<()> {
        let columns = [
            Column {
                ply: &["vx", "vy", "vz"],
                vtk: "velocity",
                values: Values::Vec3(&self.vel),
            },
            Column::scalar(&"mass", Values::F32(&self.mass)),
            Column::scalar(&"radius", Values::F32(&self.radius)),
            Column::scalar(&"object", Values::I32(&self.object)),
            Column {
                ply: &["ux", "uy", "uz"],
                vtk: "displacement",
                values: Values::Vec3(&self.displacement),
            },
            Column {
                ply: &[
                    "strain_xx",
                    "strain_yy",
                    "strain_zz",
                    "strain_xy",
                    "strain_yz",
                    "strain_zx",
                ],
                vtk: "strain",
                values: Values::Sym(&self.strain),
            },
            Column {
                ply: &[
                    "stress_xx",
                    "stress_yy",
                    "stress_zz",
                    "stress_xy",
                    "stress_yz",
                    "stress_zx",
                ],
                vtk: "stress",
                values: Values::Sym(&self.stress),
            },
            Column::scalar(&"von_mises", Values::F32(&self.von_mises)),
        ];
        let points = Points {
            pos: &self.pos,
            columns: &columns,
            triangles: &[],
        };
        match format {
            Format::Ply => points.write_ply(path, "phyxel phyxels"),
            Format::Vtk => points.write_vtp(path),
        }
    }
}

/// The output meshes of every object that has one ([`crate::body::object::Object::mesh`]),
/// as one triangle mesh: vertices with normals from the deformed triangles (a point
/// cloud's: its points, with their own normals and no triangles) and the object's id,
/// triangles indexing them. Call [`World::follow_meshes`] first so that the
/// vertices are where this step's field puts them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshFrame {
    pub pos: Vec<Vec3>,
    pub normal: Vec<Vec3>,
    pub object: Vec<i32>,
    pub triangles: Vec<[u32; 3]>,
}

/// The mesh frame of `world` (see [`MeshFrame`]).
pub fn mesh_frame(world: &World) -> MeshFrame {
    let mut f = MeshFrame::default();
    for o in &world.objects {
        let Some(m) = &o.mesh else { continue };
        let first = f.pos.len() as u32;
        let pos = m.positions();
        f.normal.extend(m.normals());
        f.object.extend(pos.iter().map(|_| o.id as i32));
        f.pos.extend(pos);
        f.triangles
            .extend(m.triangles.iter().map(|t| t.map(|v| v + first)));
    }
    f
}

impl MeshFrame {
    /// Writes the frame to `path` in `format`: PLY `x y z nx ny nz object` and a `face`
    /// element, or VTK polygons with `Normals` and `object`.
    pub fn write(&self, path: &Path, format: Format) -> std::io::Result<()> {
        let columns = [
            Column::normals(&self.normal),
            Column::scalar(&"object", Values::I32(&self.object)),
        ];
        let points = Points {
            pos: &self.pos,
            columns: &columns,
            triangles: &self.triangles,
        };
        match format {
            Format::Ply => points.write_ply(path, "phyxel meshes"),
            Format::Vtk => points.write_vtp(path),
        }
    }
}

/// The name of frame `frame`'s mesh file in `format` (`mesh_NNNNN.ply` or `.vtp`).
pub fn mesh_file(frame: u64, format: Format) -> String {
    format!("mesh_{frame:05}.{}", format.extension())
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
            Column::scalar(&"area", Values::F32(&self.area)),
            Column::scalar(&"penetration", Values::F32(&self.penetration)),
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
            Column::scalar(&"a", Values::I32(&self.a)),
            Column::scalar(&"b", Values::I32(&self.b)),
        ];
        let points = Points {
            pos: &self.pos,
            columns: &columns,
            triangles: &[],
        };
        match format {
            Format::Ply => points.write_ply(path, "phyxel contact surfels"),
            Format::Vtk => points.write_vtp(path),
        }
    }
}
