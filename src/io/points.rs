//! A point cloud with named per-point columns, and its two writers: binary
//! little-endian PLY and ASCII VTK XML PolyData (`.vtp`, each point a vertex cell).
//! The surfel frames ([`super::frame::Frame`]) and the contact frames
//! ([`crate::world::output::contact_frame`]) are both written through it.

use super::atomic::AtomicFile;
use glam::Vec3;
use std::io::Write;
use std::path::Path;

/// The values of one column, one per point.
#[derive(Clone, Copy, Debug)]
pub enum Values<'a> {
    F32(&'a [f32]),
    /// Three components: three PLY properties, one three-component VTK array.
    Vec3(&'a [Vec3]),
    I32(&'a [i32]),
    U8(&'a [u8]),
}

/// A named column. `ply` holds its PLY property name, or the three names of a
/// [`Values::Vec3`]'s components; `vtk` its VTK array name.
#[derive(Clone, Copy, Debug)]
pub struct Column<'a> {
    pub ply: &'a [&'a str],
    pub vtk: &'a str,
    pub values: Values<'a>,
}

impl<'a> Column<'a> {
    /// Unit normals: PLY `nx ny nz`, VTK `Normals` (which ParaView shades with).
    pub fn normals(values: &'a [Vec3]) -> Self {
        Column {
            ply: &["nx", "ny", "nz"],
            vtk: "Normals",
            values: Values::Vec3(values),
        }
    }
}

impl Values<'_> {
    fn len(&self) -> usize {
        match self {
            Values::F32(v) => v.len(),
            Values::Vec3(v) => v.len(),
            Values::I32(v) => v.len(),
            Values::U8(v) => v.len(),
        }
    }

    fn ply_type(&self) -> &'static str {
        match self {
            Values::F32(_) | Values::Vec3(_) => "float",
            Values::I32(_) => "int",
            Values::U8(_) => "uchar",
        }
    }

    fn vtk_type(&self) -> (&'static str, usize) {
        match self {
            Values::F32(_) => ("Float32", 1),
            Values::Vec3(_) => ("Float32", 3),
            Values::I32(_) => ("Int32", 1),
            Values::U8(_) => ("UInt8", 1),
        }
    }

    fn write_le(&self, w: &mut impl Write, i: usize) -> std::io::Result<()> {
        match self {
            Values::F32(v) => w.write_all(&v[i].to_le_bytes()),
            Values::Vec3(v) => {
                for c in v[i].to_array() {
                    w.write_all(&c.to_le_bytes())?;
                }
                Ok(())
            }
            Values::I32(v) => w.write_all(&v[i].to_le_bytes()),
            Values::U8(v) => w.write_all(&[v[i]]),
        }
    }

    fn write_ascii(&self, w: &mut impl Write, i: usize) -> std::io::Result<()> {
        match self {
            Values::F32(v) => writeln!(w, "{}", v[i]),
            Values::Vec3(v) => writeln!(w, "{} {} {}", v[i].x, v[i].y, v[i].z),
            Values::I32(v) => writeln!(w, "{}", v[i]),
            Values::U8(v) => writeln!(w, "{}", v[i]),
        }
    }
}

/// Points and their columns (every column as long as `pos`).
#[derive(Clone, Copy, Debug)]
pub struct Points<'a> {
    pub pos: &'a [Vec3],
    pub columns: &'a [Column<'a>],
}

impl Points<'_> {
    fn check(&self) {
        for c in self.columns {
            assert_eq!(c.values.len(), self.pos.len(), "column {}", c.vtk);
        }
    }

    /// Binary little-endian PLY, one `vertex` element: `x y z` then the columns in order.
    pub fn write_ply(&self, path: &Path, comment: &str) -> std::io::Result<()> {
        self.check();
        let mut w = create(path)?;
        let n = self.pos.len();
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment {comment}\nelement vertex {n}\n\
             property float x\nproperty float y\nproperty float z\n"
        )?;
        for c in self.columns {
            for name in c.ply {
                writeln!(w, "property {} {name}", c.values.ply_type())?;
            }
        }
        writeln!(w, "end_header")?;
        for i in 0..n {
            Values::Vec3(self.pos).write_le(&mut w, i)?;
            for c in self.columns {
                c.values.write_le(&mut w, i)?;
            }
        }
        w.commit()
    }

    /// VTK XML PolyData (ASCII): the points as vertex cells, the columns as point data.
    /// A column named `Normals` is the data's normals; the first scalar column its
    /// scalars.
    pub fn write_vtp(&self, path: &Path) -> std::io::Result<()> {
        self.check();
        let mut w = create(path)?;
        let n = self.pos.len();
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
        let mut attrs = String::new();
        if self.columns.iter().any(|c| c.vtk == "Normals") {
            attrs.push_str(" Normals=\"Normals\"");
        }
        if let Some(c) = self.columns.iter().find(|c| c.values.vtk_type().1 == 1) {
            attrs.push_str(&format!(" Scalars=\"{}\"", c.vtk));
        }
        writeln!(w, "<PointData{attrs}>")?;
        for c in self.columns {
            let (ty, k) = c.values.vtk_type();
            let comps = if k > 1 {
                format!(" NumberOfComponents=\"{k}\"")
            } else {
                String::new()
            };
            writeln!(
                w,
                "<DataArray type=\"{ty}\" Name=\"{}\"{comps} format=\"ascii\">",
                c.vtk
            )?;
            for i in 0..n {
                c.values.write_ascii(&mut w, i)?;
            }
            writeln!(w, "</DataArray>")?;
        }
        writeln!(w, "</PointData>")?;
        writeln!(
            w,
            "<Points>\n<DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"ascii\">"
        )?;
        for i in 0..n {
            Values::Vec3(self.pos).write_ascii(&mut w, i)?;
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
        w.commit()
    }
}

/// The file at `path`, replaced whole when committed ([`AtomicFile`]).
fn create(path: &Path) -> std::io::Result<AtomicFile> {
    AtomicFile::create(path)
}
