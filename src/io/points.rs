//! A point cloud with named per-point columns, and its two writers: binary
//! little-endian PLY and binary VTK XML PolyData (`.vtp`, zlib-compressed, each point a
//! vertex cell).
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
    /// A symmetric tensor, six components `xx yy zz xy yz zx` (VTK's order for a
    /// six-component tensor array).
    Sym(&'a [[f32; 6]]),
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
    /// A column of one value per point, `name` in PLY and in VTK alike (pass a
    /// literal's reference, `&"mass"`).
    pub fn scalar(name: &'a &'a str, values: Values<'a>) -> Self {
        Column {
            ply: std::slice::from_ref(name),
            vtk: name,
            values,
        }
    }

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
            Values::Sym(v) => v.len(),
        }
    }

    fn ply_type(&self) -> &'static str {
        match self {
            Values::F32(_) | Values::Vec3(_) | Values::Sym(_) => "float",
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
            Values::Sym(_) => ("Float32", 6),
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
            Values::Sym(v) => {
                for c in v[i] {
                    w.write_all(&c.to_le_bytes())?;
                }
                Ok(())
            }
        }
    }

    /// Every value, little-endian, in point order.
    fn le_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.len() * 12);
        for i in 0..self.len() {
            self.write_le(&mut out, i).expect("writing to memory");
        }
        out
    }
}

/// Points and their columns (every column as long as `pos`), and the triangles over
/// them when they are a mesh's vertices (empty: a point cloud).
#[derive(Clone, Copy, Debug)]
pub struct Points<'a> {
    pub pos: &'a [Vec3],
    pub columns: &'a [Column<'a>],
    pub triangles: &'a [[u32; 3]],
}

impl Points<'_> {
    fn check(&self) {
        for c in self.columns {
            assert_eq!(c.values.len(), self.pos.len(), "column {}", c.vtk);
            assert_eq!(
                c.ply.len(),
                c.values.vtk_type().1,
                "column {}'s PLY names",
                c.vtk
            );
        }
    }

    /// Binary little-endian PLY, one `vertex` element: `x y z` then the columns in order,
    /// and a `face` element (`vertex_indices`) when there are triangles.
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
        if !self.triangles.is_empty() {
            writeln!(w, "element face {}", self.triangles.len())?;
            writeln!(w, "property list uchar int vertex_indices")?;
        }
        writeln!(w, "end_header")?;
        for i in 0..n {
            Values::Vec3(self.pos).write_le(&mut w, i)?;
            for c in self.columns {
                c.values.write_le(&mut w, i)?;
            }
        }
        for t in self.triangles {
            w.write_all(&[3])?;
            for v in t {
                w.write_all(&(*v as i32).to_le_bytes())?;
            }
        }
        w.commit()
    }

    /// VTK XML PolyData, binary: the points as vertex cells (or the triangles as
    /// polygons), the columns as point data,
    /// every array zlib-compressed in the appended data block (`vtkZLibDataCompressor`,
    /// UInt64 headers), as ParaView and VTK read it. A column named `Normals` is the
    /// data's normals; the first scalar column its scalars.
    pub fn write_vtp(&self, path: &Path) -> std::io::Result<()> {
        self.check();
        let n = self.pos.len();
        let mut xml = String::new();
        let mut data: Vec<u8> = Vec::new();
        // One `<DataArray>` whose values go, compressed, to the appended block.
        let mut array = |xml: &mut String, ty: &str, name: &str, comps: usize, raw: &[u8]| {
            let name = if name.is_empty() {
                String::new()
            } else {
                format!(" Name=\"{name}\"")
            };
            xml.push_str(&format!(
                "<DataArray type=\"{ty}\"{name} NumberOfComponents=\"{comps}\" \
                 format=\"appended\" offset=\"{}\"/>\n",
                data.len()
            ));
            append_compressed(&mut data, raw);
        };
        // Triangles as polygons, else each point a vertex cell.
        let (cells, size, tag) = match self.triangles.len() {
            0 => (n, 1, "Verts"),
            t => (t, 3, "Polys"),
        };
        let (verts, polys) = if tag == "Verts" { (n, 0) } else { (0, cells) };
        xml.push_str(&format!(
            "<Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"{verts}\" NumberOfLines=\"0\" \
             NumberOfStrips=\"0\" NumberOfPolys=\"{polys}\">\n"
        ));
        let mut attrs = String::new();
        if self.columns.iter().any(|c| c.vtk == "Normals") {
            attrs.push_str(" Normals=\"Normals\"");
        }
        if let Some(c) = self.columns.iter().find(|c| c.values.vtk_type().1 == 1) {
            attrs.push_str(&format!(" Scalars=\"{}\"", c.vtk));
        }
        xml.push_str(&format!("<PointData{attrs}>\n"));
        for c in self.columns {
            let (ty, k) = c.values.vtk_type();
            array(&mut xml, ty, c.vtk, k, &c.values.le_bytes());
        }
        xml.push_str("</PointData>\n<Points>\n");
        array(
            &mut xml,
            "Float32",
            "",
            3,
            &Values::Vec3(self.pos).le_bytes(),
        );
        xml.push_str(&format!("</Points>\n<{tag}>\n"));
        let ints = |v: &mut dyn Iterator<Item = usize>| -> Vec<u8> {
            v.flat_map(|i| (i as i64).to_le_bytes()).collect()
        };
        let connectivity = match tag {
            "Verts" => ints(&mut (0..n)),
            _ => ints(&mut self.triangles.iter().flatten().map(|&v| v as usize)),
        };
        array(&mut xml, "Int64", "connectivity", 1, &connectivity);
        let offsets = ints(&mut (1..=cells).map(|c| c * size));
        array(&mut xml, "Int64", "offsets", 1, &offsets);
        xml.push_str(&format!("</{tag}>\n</Piece>\n"));
        let mut w = create(path)?;
        writeln!(w, "<?xml version=\"1.0\"?>")?;
        writeln!(
            w,
            "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" \
             header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\">"
        )?;
        write!(
            w,
            "<PolyData>\n{xml}</PolyData>\n<AppendedData encoding=\"raw\">\n_"
        )?;
        w.write_all(&data)?;
        writeln!(w, "\n</AppendedData>\n</VTKFile>")?;
        w.commit()
    }
}

/// Uncompressed bytes per block of a compressed VTK array.
const VTK_BLOCK: usize = 1 << 20;

/// `raw` as a compressed VTK array (`vtkZLibDataCompressor`, UInt64 header): the block
/// count, the block size, the last block's size if partial (else 0), each block's
/// compressed size, then the blocks (compressed in parallel). Fast compression: frames
/// are written every few steps, and the sorted columns (connectivity, offsets, object)
/// shrink most of it.
fn append_compressed(out: &mut Vec<u8>, raw: &[u8]) {
    use flate2::{Compression, write::ZlibEncoder};
    use rayon::prelude::*;
    let blocks: Vec<Vec<u8>> = raw
        .par_chunks(VTK_BLOCK)
        .map(|b| {
            let mut z = ZlibEncoder::new(Vec::new(), Compression::fast());
            z.write_all(b).expect("writing to memory");
            z.finish().expect("writing to memory")
        })
        .collect();
    let header = [
        blocks.len() as u64,
        VTK_BLOCK as u64,
        (raw.len() % VTK_BLOCK) as u64,
    ];
    for v in header
        .into_iter()
        .chain(blocks.iter().map(|b| b.len() as u64))
    {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for b in &blocks {
        out.extend_from_slice(b);
    }
}

/// The file at `path`, replaced whole when committed ([`AtomicFile`]).
fn create(path: &Path) -> std::io::Result<AtomicFile> {
    AtomicFile::create(path)
}
