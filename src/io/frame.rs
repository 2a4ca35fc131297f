//! One output frame of the render surface as plain columns, and its writers: binary PLY
//! (what `--out` writes by default) and VTK XML PolyData (`.vtp`, for ParaView).

use glam::Vec3;
use std::fs::File;
use std::io::{BufWriter, Write};
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
    /// VTK XML PolyData, ASCII (`.vtp`).
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

    /// Binary little-endian PLY: `x y z nx ny nz radius` (float), `object` (int),
    /// `contact` (uchar).
    pub fn write_ply(&self, path: &Path) -> std::io::Result<()> {
        let mut w = create(path)?;
        let n = self.len();
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment phyxel render surface\nelement vertex {n}\n\
             property float x\nproperty float y\nproperty float z\n\
             property float nx\nproperty float ny\nproperty float nz\n\
             property float radius\nproperty int object\nproperty uchar contact\nend_header\n"
        )?;
        for i in 0..n {
            let (p, nrm) = (self.pos[i], self.normal[i]);
            for v in [p.x, p.y, p.z, nrm.x, nrm.y, nrm.z, self.radius[i]] {
                w.write_all(&v.to_le_bytes())?;
            }
            w.write_all(&self.object[i].to_le_bytes())?;
            w.write_all(&[self.contact[i]])?;
        }
        w.flush()
    }

    /// VTK XML PolyData (ASCII): points as vertices, point data `Normals`, `radius`,
    /// `object`, `contact`.
    pub fn write_vtp(&self, path: &Path) -> std::io::Result<()> {
        let mut w = create(path)?;
        let n = self.len();
        writeln!(w, "<?xml version=\"1.0\"?>")?;
        writeln!(
            w,
            "<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">"
        )?;
        writeln!(w, "<PolyData>")?;
        writeln!(
            w,
            "<Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"{n}\" NumberOfLines=\"0\" \
             NumberOfStrips=\"0\" NumberOfPolys=\"0\">"
        )?;
        writeln!(
            w,
            "<PointData Normals=\"Normals\" Scalars=\"radius\">\n\
             <DataArray type=\"Float32\" Name=\"Normals\" NumberOfComponents=\"3\" format=\"ascii\">"
        )?;
        for v in &self.normal {
            writeln!(w, "{} {} {}", v.x, v.y, v.z)?;
        }
        writeln!(
            w,
            "</DataArray>\n<DataArray type=\"Float32\" Name=\"radius\" format=\"ascii\">"
        )?;
        for r in &self.radius {
            writeln!(w, "{r}")?;
        }
        writeln!(
            w,
            "</DataArray>\n<DataArray type=\"Int32\" Name=\"object\" format=\"ascii\">"
        )?;
        for o in &self.object {
            writeln!(w, "{o}")?;
        }
        writeln!(
            w,
            "</DataArray>\n<DataArray type=\"UInt8\" Name=\"contact\" format=\"ascii\">"
        )?;
        for c in &self.contact {
            writeln!(w, "{c}")?;
        }
        writeln!(w, "</DataArray>\n</PointData>")?;
        writeln!(
            w,
            "<Points>\n<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">"
        )?;
        for p in &self.pos {
            writeln!(w, "{} {} {}", p.x, p.y, p.z)?;
        }
        writeln!(w, "</DataArray>\n</Points>")?;
        writeln!(
            w,
            "<Verts>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">"
        )?;
        for i in 0..n {
            writeln!(w, "{i}")?;
        }
        writeln!(
            w,
            "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">"
        )?;
        for i in 1..=n {
            writeln!(w, "{i}")?;
        }
        writeln!(
            w,
            "</DataArray>\n</Verts>\n</Piece>\n</PolyData>\n</VTKFile>"
        )?;
        w.flush()
    }
}

fn create(path: &Path) -> std::io::Result<BufWriter<File>> {
    File::create(path)
        .map(BufWriter::new)
        .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", path.display())))
}
