//! A run's frames as one USD stage in the text format (`.usda`): a `Mesh` prim per
//! object's output mesh and `Points` prims for surfels or phyxels, their points
//! time-sampled at each frame's time code, so that Blender, Houdini, Omniverse and
//! `usdview` play the run as animation.
//!
//! USD's text layer keeps an attribute's time samples inside its prim, so a stage
//! cannot be appended frame by frame: each frame's points go to a working file
//! ([`Scratch`]) as they come, and [`UsdSeries::finish`] writes the stage from it,
//! whole or not at all ([`AtomicFile`]). Memory stays that of one frame however long
//! the run.
//!
//! Time codes are simulated time times `timeCodesPerSecond` (one code per frame when
//! frames are evenly spaced); `metersPerUnit = 1` and `upAxis = "Y"` say the engine's
//! units and axes. A prim absent from some frames (a fragment born in a fracture, a body
//! that broke apart) is `invisible` there. A mesh whose vertex or triangle count changes
//! goes on in a new prim.

use super::atomic::{AtomicFile, Scratch};
use glam::Vec3;
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// What a prim holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PrimKind {
    /// A triangle mesh (`UsdGeomMesh`).
    Mesh,
    /// An object's surfels (`UsdGeomPoints`, widths the disk diameters).
    Surfels,
    /// An object's phyxels (`UsdGeomPoints`, widths twice the radii).
    Phyxels,
    /// A point-cloud shape's output points (`UsdGeomPoints`).
    Cloud,
}

impl PrimKind {
    fn suffix(self) -> &'static str {
        match self {
            PrimKind::Mesh | PrimKind::Cloud => "",
            PrimKind::Surfels => "_surfels",
            PrimKind::Phyxels => "_phyxels",
        }
    }
}

/// One frame's points of one prim in the working file.
struct Sample {
    frame: usize,
    /// Byte offset of the positions (then the widths, for points) in the working file.
    offset: u64,
    count: usize,
    lo: Vec3,
    hi: Vec3,
}

struct Prim {
    name: String,
    kind: PrimKind,
    /// A mesh's triangles (fixed for the prim).
    triangles: Vec<[u32; 3]>,
    samples: Vec<Sample>,
}

/// A USD stage being written (see the module doc).
pub struct UsdSeries {
    dest: PathBuf,
    scratch: Scratch,
    spill: BufWriter<File>,
    offset: u64,
    prims: Vec<Prim>,
    /// The prim each (object id, kind) writes to now.
    current: HashMap<(u32, PrimKind), usize>,
    names: HashMap<String, usize>,
    /// Each frame's time code.
    codes: Vec<f64>,
    codes_per_second: f64,
}

impl UsdSeries {
    /// Starts the stage `dest`, `codes_per_second` time codes per simulated second.
    pub fn create(dest: &Path, codes_per_second: f64) -> std::io::Result<Self> {
        crate::io::atomic::check_output(dest).map_err(|e| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("{}: {e}", dest.display()),
            )
        })?;
        let scratch = Scratch::create(dest)?;
        let spill = BufWriter::new(scratch.file.try_clone()?);
        Ok(Self {
            dest: dest.to_path_buf(),
            scratch,
            spill,
            offset: 0,
            prims: Vec::new(),
            current: HashMap::new(),
            names: HashMap::new(),
            codes: Vec::new(),
            codes_per_second,
        })
    }

    /// Starts a frame at simulated time `time` (s).
    pub fn begin_frame(&mut self, time: f64) {
        // A step lowered after a fracture leaves codes a rounding off whole numbers.
        let code = time * self.codes_per_second;
        let whole = code.round();
        let code = if (code - whole).abs() <= 1e-9 * whole.abs().max(1.0) {
            whole
        } else {
            code
        };
        self.codes.push(code);
    }

    /// Frames begun so far.
    pub fn frames(&self) -> usize {
        self.codes.len()
    }

    /// Adds object `object`'s (named `name`) mesh to the frame: `pos` and its triangles.
    pub fn mesh(
        &mut self,
        object: u32,
        name: &str,
        pos: &[Vec3],
        triangles: &[[u32; 3]],
    ) -> std::io::Result<()> {
        let k = self.prim(object, name, PrimKind::Mesh, |p| {
            p.triangles == triangles && p.samples.first().is_none_or(|s| s.count == pos.len())
        });
        if self.prims[k].samples.is_empty() {
            self.prims[k].triangles = triangles.to_vec();
        }
        self.sample(k, pos, &[])
    }

    /// Adds object `object`'s surfels or phyxels (`kind`) to the frame: `pos` and each
    /// point's width (m).
    pub fn points(
        &mut self,
        object: u32,
        name: &str,
        kind: PrimKind,
        pos: &[Vec3],
        widths: &[f32],
    ) -> std::io::Result<()> {
        debug_assert_eq!(pos.len(), widths.len());
        let k = self.prim(object, name, kind, |_| true);
        self.sample(k, pos, widths)
    }

    /// The prim of (`object`, `kind`) that takes this frame's points: the current one
    /// if `fits` it, else a new one under a unique name.
    fn prim(
        &mut self,
        object: u32,
        name: &str,
        kind: PrimKind,
        fits: impl Fn(&Prim) -> bool,
    ) -> usize {
        if let Some(&k) = self.current.get(&(object, kind))
            && fits(&self.prims[k])
        {
            return k;
        }
        let base = format!("{}{}", identifier(name), kind.suffix());
        let mut unique = base.clone();
        let mut n = 1;
        while self.names.contains_key(&unique) {
            unique = format!("{base}_{n}");
            n += 1;
        }
        let k = self.prims.len();
        self.names.insert(unique.clone(), k);
        self.prims.push(Prim {
            name: unique,
            kind,
            triangles: Vec::new(),
            samples: Vec::new(),
        });
        self.current.insert((object, kind), k);
        k
    }

    fn sample(&mut self, k: usize, pos: &[Vec3], widths: &[f32]) -> std::io::Result<()> {
        let frame = self.codes.len().saturating_sub(1);
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in pos {
            lo = lo.min(*p);
            hi = hi.max(*p);
            for c in p.to_array() {
                self.spill.write_all(&c.to_le_bytes())?;
            }
        }
        for w in widths {
            self.spill.write_all(&w.to_le_bytes())?;
        }
        let sample = Sample {
            frame,
            offset: self.offset,
            count: pos.len(),
            lo,
            hi,
        };
        self.offset += 4 * (3 * pos.len() + widths.len()) as u64;
        let prim = &mut self.prims[k];
        match prim.samples.last_mut() {
            // Twice in one frame: the last one holds.
            Some(last) if last.frame == frame => *last = sample,
            _ => prim.samples.push(sample),
        }
        Ok(())
    }

    /// Writes the stage (whole or not at all) and removes the working file.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.spill.flush()?;
        let mut read = self.scratch.file.try_clone()?;
        let mut out = AtomicFile::create(&self.dest)?;
        let first = self.codes.first().copied().unwrap_or(0.0);
        let last = self.codes.last().copied().unwrap_or(0.0);
        write!(
            out,
            "#usda 1.0\n(\n    defaultPrim = \"World\"\n    doc = \"phyxel run frames: \
             one Mesh per object, Points for surfels and phyxels when written\"\n    \
             metersPerUnit = 1\n    upAxis = \"Y\"\n    startTimeCode = {}\n    \
             endTimeCode = {}\n    timeCodesPerSecond = {}\n    framesPerSecond = {}\n)\n\n\
             def Xform \"World\"\n{{\n",
            number(first),
            number(last),
            number(self.codes_per_second),
            number(self.codes_per_second),
        )?;
        let mut buf = Vec::new();
        for prim in &self.prims {
            let schema = match prim.kind {
                PrimKind::Mesh => "Mesh",
                _ => "Points",
            };
            writeln!(out, "    def {schema} \"{}\"\n    {{", prim.name)?;
            if prim.kind == PrimKind::Mesh {
                write!(out, "        int[] faceVertexCounts = [")?;
                for (i, _) in prim.triangles.iter().enumerate() {
                    write!(out, "{}3", if i > 0 { ", " } else { "" })?;
                }
                write!(out, "]\n        int[] faceVertexIndices = [")?;
                for (i, t) in prim.triangles.iter().enumerate() {
                    let sep = if i > 0 { ", " } else { "" };
                    write!(out, "{sep}{}, {}, {}", t[0], t[1], t[2])?;
                }
                writeln!(out, "]\n        uniform token subdivisionScheme = \"none\"")?;
            }
            writeln!(out, "        float3[] extent.timeSamples = {{")?;
            for s in &prim.samples {
                let (lo, hi) = if s.count > 0 {
                    (s.lo, s.hi)
                } else {
                    (Vec3::ZERO, Vec3::ZERO)
                };
                writeln!(
                    out,
                    "            {}: [({}, {}, {}), ({}, {}, {})],",
                    number(self.codes[s.frame]),
                    lo.x,
                    lo.y,
                    lo.z,
                    hi.x,
                    hi.y,
                    hi.z
                )?;
            }
            writeln!(out, "        }}")?;
            let with_widths = prim.kind != PrimKind::Mesh;
            for (attribute, widths) in [("point3f[] points", false), ("float[] widths", true)] {
                if widths && !with_widths {
                    continue;
                }
                writeln!(out, "        {attribute}.timeSamples = {{")?;
                for s in &prim.samples {
                    let (at, len) = if widths {
                        (s.offset + 12 * s.count as u64, 4 * s.count)
                    } else {
                        (s.offset, 12 * s.count)
                    };
                    buf.resize(len, 0);
                    read.seek(SeekFrom::Start(at))?;
                    read.read_exact(&mut buf)?;
                    let f = |i: usize| {
                        f32::from_le_bytes(buf[4 * i..4 * i + 4].try_into().expect("4 bytes"))
                    };
                    write!(out, "            {}: [", number(self.codes[s.frame]))?;
                    for i in 0..s.count {
                        let sep = if i > 0 { ", " } else { "" };
                        if widths {
                            write!(out, "{sep}{}", f(i))?;
                        } else {
                            let (x, y, z) = (f(3 * i), f(3 * i + 1), f(3 * i + 2));
                            write!(out, "{sep}({x}, {y}, {z})")?;
                        }
                    }
                    writeln!(out, "],")?;
                }
                writeln!(out, "        }}")?;
            }
            if with_widths {
                writeln!(
                    out,
                    "        uniform token widths:interpolation = \"vertex\""
                )?;
            }
            self.visibility(&mut out, prim)?;
            writeln!(out, "    }}")?;
        }
        writeln!(out, "}}")?;
        out.commit()
    }

    /// `visibility` samples where the prim appears and disappears, if it is missing
    /// from any frame.
    fn visibility(&self, out: &mut impl Write, prim: &Prim) -> std::io::Result<()> {
        let mut present = vec![false; self.codes.len()];
        for s in &prim.samples {
            present[s.frame] = true;
        }
        if present.iter().all(|&p| p) {
            return Ok(());
        }
        writeln!(out, "        token visibility.timeSamples = {{")?;
        let mut last = None;
        for (frame, &p) in present.iter().enumerate() {
            if last != Some(p) {
                let token = if p { "inherited" } else { "invisible" };
                writeln!(
                    out,
                    "            {}: \"{token}\",",
                    number(self.codes[frame])
                )?;
                last = Some(p);
            }
        }
        writeln!(out, "        }}")
    }
}

/// A USD identifier from an object's name: letters, digits and `_`, not starting with
/// a digit (`bar.1.0` → `bar_1_0`, `2-spheres` → `_2_spheres`).
fn identifier(name: &str) -> String {
    let mut id: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if id.is_empty() || id.starts_with(|c: char| c.is_ascii_digit()) {
        id.insert(0, '_');
    }
    id
}

/// A time code or rate: integers without a fraction, others in full.
fn number(x: f64) -> String {
    if x.fract() == 0.0 && x.abs() < 1e15 {
        format!("{}", x as i64)
    } else {
        format!("{x}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identifiers_are_usd_names() {
        assert_eq!(identifier("bar.1.0"), "bar_1_0");
        assert_eq!(identifier("2-spheres"), "_2_spheres");
        assert_eq!(identifier(""), "_");
        assert_eq!(identifier("ball"), "ball");
    }
}
