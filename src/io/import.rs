//! Reading files in: PLY frames (for `phyxel render` and round trips) and, through the
//! same PLY reader, triangle meshes and point clouds. Every error names the file and,
//! where there is one, the element or line.

use crate::io::frame::Frame;
use glam::Vec3;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{DefaultElement, Encoding, Header, Payload, Property};
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

/// A parsed PLY file: its header and every element, in header order.
pub struct PlyFile {
    pub header: Header,
    pub payload: Payload<DefaultElement>,
}

/// Reads a whole PLY file (ASCII or binary). Errors name the file, and for a payload cut
/// short or malformed, the element name and index (binary) or line (ASCII).
pub fn read_ply(path: &Path) -> Result<PlyFile, String> {
    read_ply_raw(path).map_err(|e| shown(&e))
}

/// Longest error message [`read_ply`] returns (characters): the PLY parser's messages
/// quote the offending line and its own state.
const MESSAGE_CHARS: usize = 400;

/// `message` as it may reach a terminal: control characters other than line breaks
/// and tabs escaped (the parser quotes file content, so a NUL or an escape sequence
/// would come through raw), cut to [`MESSAGE_CHARS`].
fn shown(message: &str) -> String {
    let mut s = String::new();
    for (k, c) in message.chars().enumerate() {
        if k == MESSAGE_CHARS {
            s.push('…');
            break;
        }
        match c {
            '\n' | '\t' => s.push(c),
            c if c.is_control() => s.extend(c.escape_debug()),
            c => s.push(c),
        }
    }
    s
}

fn read_ply_raw(path: &Path) -> Result<PlyFile, String> {
    let name = path.display();
    super::check_input_file(path, super::INPUT_FILE_LIMIT).map_err(|e| format!("{name}: {e}"))?;
    let file = File::open(path).map_err(|e| format!("{name}: cannot open: {e}"))?;
    let mut buffered = BufReader::new(file);
    let start = buffered
        .fill_buf()
        .map_err(|e| format!("{name}: cannot read: {e}"))?;
    if !start.starts_with(b"ply") {
        return Err(format!("{name}: {}", not_ply(start)));
    }
    let mut reader = Reader::new(buffered);
    let parser = Parser::<DefaultElement>::new();
    let header = parser
        .read_header(&mut reader)
        .map_err(|e| format!("{name}: bad PLY header: {e}"))?;
    let mut payload = Payload::with_capacity(header.elements.len());
    for (key, def) in &header.elements {
        let elems = match header.encoding {
            Encoding::Ascii => parser
                .read_payload_for_element(&mut reader, def, &header)
                .map_err(|e| format!("{name}: element '{key}': {e}"))?,
            Encoding::BinaryLittleEndian | Encoding::BinaryBigEndian => {
                let mut v = Vec::with_capacity(def.count.min(1 << 24));
                for i in 0..def.count {
                    let r = if header.encoding == Encoding::BinaryLittleEndian {
                        parser.read_little_endian_element(reader.get_mut(), def)
                    } else {
                        parser.read_big_endian_element(reader.get_mut(), def)
                    };
                    let e = r.map_err(|e| {
                        let what = if e.kind() == std::io::ErrorKind::UnexpectedEof {
                            "file cut short (binary PLY truncated)".to_string()
                        } else {
                            e.to_string()
                        };
                        format!("{name}: element '{key}' {i} of {}: {what}", def.count)
                    })?;
                    v.push(e);
                }
                v
            }
        };
        payload.insert(key.clone(), elems);
    }
    check_nothing_after(&name.to_string(), &header, reader.get_mut())?;
    Ok(PlyFile { header, payload })
}

/// Why a file that does not start with the PLY magic word is not read, from its first
/// bytes: the parser's own message is a multi-line dump of its expected tokens (for the
/// `.vtp` frames `run --format vtk` writes, too).
fn not_ply(start: &[u8]) -> String {
    if start.is_empty() {
        return "not a PLY file: it is empty".to_string();
    }
    let first_line = start.split(|&b| b == b'\n').next().unwrap_or(start);
    let text = std::str::from_utf8(first_line)
        .ok()
        .map(|t| t.trim_end_matches('\r'))
        .filter(|t| !t.chars().any(|c| c.is_control() && c != '\t'));
    let Some(text) = text else {
        return "not a PLY file: it starts with binary data, not 'ply'".to_string();
    };
    let mut shown: String = text.chars().take(40).collect();
    if shown.len() < text.len() {
        shown.push_str("...");
    }
    let hint = if start.starts_with(b"<?xml") || start.starts_with(b"<VTKFile") {
        " (XML: a VTK frame, as `run --format vtk` writes; only PLY is read, so write the \
         frames with the default `--format ply`)"
    } else {
        ""
    };
    format!("not a PLY file: it starts with '{shown}', not 'ply'{hint}")
}

/// Data after the last declared element means the header's counts do not match the
/// data (a reader that stopped there would silently drop points): an error, except for
/// trailing white space in an ASCII file.
fn check_nothing_after(
    name: &str,
    header: &Header,
    rest: &mut impl std::io::Read,
) -> Result<(), String> {
    let mut tail = Vec::new();
    rest.read_to_end(&mut tail)
        .map_err(|e| format!("{name}: reading after the last element: {e}"))?;
    let extra = if header.encoding == Encoding::Ascii {
        tail.iter()
            .position(|b| !b.is_ascii_whitespace())
            .map(|at| &tail[at..])
    } else {
        (!tail.is_empty()).then_some(&tail[..])
    };
    let Some(extra) = extra else {
        return Ok(());
    };
    let counts: Vec<String> = header
        .elements
        .iter()
        .map(|(k, d)| format!("{} '{k}'", d.count))
        .collect();
    let shown = if header.encoding == Encoding::Ascii {
        let line = String::from_utf8_lossy(extra);
        let line = line
            .lines()
            .next()
            .unwrap_or("")
            .chars()
            .take(40)
            .collect::<String>();
        format!(": \"{line}\"")
    } else {
        String::new()
    };
    Err(format!(
        "{name}: {} bytes after the declared elements ({}){shown}: the header's element \
         counts do not match the data",
        extra.len(),
        counts.join(", ")
    ))
}

/// A scalar property of element `i` as f32, or an error naming the file and element.
fn scalar(file: &str, elem: &str, i: usize, e: &DefaultElement, prop: &str) -> Result<f32, String> {
    match e.get(prop) {
        Some(p) => p
            .to_f32_lossy()
            .ok_or_else(|| format!("{file}: element '{elem}' {i}: property '{prop}' is a list")),
        None => Err(format!("{file}: element '{elem}' has no property '{prop}'")),
    }
}

fn integer(p: Option<&Property>) -> Option<i64> {
    Some(match p? {
        Property::Char(v) => *v as i64,
        Property::UChar(v) => *v as i64,
        Property::Short(v) => *v as i64,
        Property::UShort(v) => *v as i64,
        Property::Int(v) => *v as i64,
        Property::UInt(v) => *v as i64,
        Property::Float(v) => *v as i64,
        Property::Double(v) => *v as i64,
        _ => return None,
    })
}

/// Reads a surfel frame written by `phyxel run --out` (or any PLY point cloud with
/// `x y z`; normals, `radius`, `object` and `contact` are optional, defaulting to
/// +z, 0, 0 and 0). A radius of 0 means "unknown": the renderer picks one.
pub fn read_frame(path: &Path) -> Result<Frame, String> {
    let ply = read_ply(path)?;
    let file = path.display().to_string();
    let verts = ply
        .payload
        .get("vertex")
        .ok_or_else(|| format!("{file}: no 'vertex' element"))?;
    let mut frame = Frame::default();
    for (i, e) in verts.iter().enumerate() {
        let get = |p: &str| scalar(&file, "vertex", i, e, p);
        let pos = Vec3::new(get("x")?, get("y")?, get("z")?);
        if !pos.is_finite() {
            return Err(format!(
                "{file}: element 'vertex' {i}: position {pos} is not finite"
            ));
        }
        let normal = if e.contains_key("nx") {
            Vec3::new(get("nx")?, get("ny")?, get("nz")?)
        } else {
            Vec3::Z
        };
        if !normal.is_finite() {
            return Err(format!(
                "{file}: element 'vertex' {i}: normal {normal} is not finite"
            ));
        }
        let radius = if e.contains_key("radius") {
            get("radius")?
        } else {
            0.0
        };
        // 0 means "unknown" (the renderer picks one); negative or non-finite is no disk.
        if !(radius.is_finite() && radius >= 0.0) {
            return Err(format!(
                "{file}: element 'vertex' {i}: radius {radius} must be finite and >= 0"
            ));
        }
        let object = integer(e.get("object")).unwrap_or(0) as i32;
        let contact = integer(e.get("contact")).unwrap_or(0).clamp(0, 255) as u8;
        frame.push(pos, normal, radius, object, contact);
    }
    Ok(frame)
}

#[cfg(test)]
mod tests {
    /// A PLY error never carries a raw control character (a NUL, an escape sequence
    /// quoted from a header line) or more than the limit: escaped exactly, cut to
    /// `MESSAGE_CHARS` plus the ellipsis.
    #[test]
    fn messages_are_escaped_and_cut() {
        let m = super::shown("Line 2: 'format \u{0}\u{1b}[31m'\n\tError");
        assert_eq!(m, "Line 2: 'format \\0\\u{1b}[31m'\n\tError");
        let long = "x".repeat(1000);
        assert_eq!(
            super::shown(&long).chars().count(),
            super::MESSAGE_CHARS + 1
        );
    }
}
