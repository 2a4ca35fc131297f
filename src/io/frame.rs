//! One output frame of the render surface as plain columns, and its writers: binary PLY
//! (what `--out` writes by default) and VTK XML PolyData (`.vtp`, for ParaView).

use super::points::{Column, Points, Values};
use glam::Vec3;
use std::path::Path;

/// Surfels of one frame: position, normal, disk radius, object id, contact flag.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Frame {
    pub pos: Vec<Vec3>,
    pub normal: Vec<Vec3>,
    pub radius: Vec<f32>,
    pub object: Vec<i32>,
    pub contact: Vec<u8>,
}

/// Frame file formats (`--format`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Format {
    /// Binary little-endian PLY (`.ply`).
    #[default]
    Ply,
    /// VTK XML PolyData, binary and zlib-compressed (`.vtp`).
    Vtk,
}

impl Format {
    /// The file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Ply => "ply",
            Format::Vtk => "vtp",
        }
    }

    /// Parses `ply` or `vtk`.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "ply" => Ok(Format::Ply),
            "vtk" | "vtp" => Ok(Format::Vtk),
            _ => Err(format!("unknown frame format '{s}' (available: ply, vtk)")),
        }
    }
}

impl Frame {
    /// Number of surfels.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// True when the frame has no surfels.
    pub fn is_empty(&self) -> bool {
        self.pos.is_empty()
    }

    /// Appends one surfel.
    pub fn push(&mut self, pos: Vec3, normal: Vec3, radius: f32, object: i32, contact: u8) {
        self.pos.push(pos);
        self.normal.push(normal);
        self.radius.push(radius);
        self.object.push(object);
        self.contact.push(contact);
    }

    /// Axis-aligned bounds of the surfel centres (`None` when empty).
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut it = self.pos.iter().filter(|p| p.is_finite());
        let first = *it.next()?;
        Some(it.fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p))))
    }

    /// Writes the frame to `path` in `format`.
    pub fn write(&self, path: &Path, format: Format) -> std::io::Result<()> {
        match format {
            Format::Ply => self.write_ply(path),
            Format::Vtk => self.write_vtp(path),
        }
    }

    /// The frame as a point table: normal, radius, object id, contact flag.
    fn points<R>(&self, f: impl FnOnce(&Points) -> R) -> R {
        let columns = [
            Column::normals(&self.normal),
            Column::scalar(&"radius", Values::F32(&self.radius)),
            Column::scalar(&"object", Values::I32(&self.object)),
            Column::scalar(&"contact", Values::U8(&self.contact)),
        ];
        f(&Points {
            pos: &self.pos,
            columns: &columns,
            triangles: &[],
        })
    }

    /// Binary little-endian PLY: `x y z nx ny nz radius` (float), `object` (int),
    /// `contact` (uchar).
    pub fn write_ply(&self, path: &Path) -> std::io::Result<()> {
        self.points(|p| p.write_ply(path, "phyxel render surface"))
    }

    /// VTK XML PolyData (binary, zlib-compressed): points as vertices, point data `Normals`, `radius`,
    /// `object`, `contact`.
    pub fn write_vtp(&self, path: &Path) -> std::io::Result<()> {
        self.points(|p| p.write_vtp(path))
    }
}
