//! Reading mesh files: OBJ (through `tobj`, with a strict check of the statements),
//! ASCII or binary PLY (triangles, or points with normals) and ASCII or binary STL
//! (through `stl_io`).

use super::*;

pub(super) type Raw = (Vec<Vec3>, Vec<[u32; 3]>);

/// OBJ statements that carry no geometry the loader uses (names, groups, smoothing,
/// materials, free-form surfaces); they are skipped. Any other keyword is an error, so a
/// damaged file does not load as a silently smaller mesh.
pub(super) const OBJ_SKIPPED: [&str; 28] = [
    "vp",
    "l",
    "p",
    "o",
    "g",
    "s",
    "mg",
    "usemtl",
    "mtllib",
    "usemap",
    "maplib",
    "lod",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "end",
];

/// The first OBJ line (1-based) whose vertex or face data does not parse, or whose
/// keyword is not OBJ's, for error messages (the OBJ parser does not report lines).
/// At most [`SNIPPET_CHARS`] characters of a file's line, control characters escaped: an
/// error may quote the line, and the file may not be a mesh at all (a link to a secret,
/// or binary data a terminal would act on).
fn snippet(line: &str) -> String {
    let mut s: String = line
        .chars()
        .take(SNIPPET_CHARS)
        .flat_map(char::escape_debug)
        .collect();
    if line.chars().count() > SNIPPET_CHARS {
        s.push('…');
    }
    s
}

/// The longest quote of a file's line in an error.
const SNIPPET_CHARS: usize = 40;

pub(super) fn obj_bad_line(path: &Path) -> Option<(usize, String)> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut vertices = 0i64;
    for (k, line) in text.lines().enumerate() {
        let mut tok = line.split_whitespace();
        let ok = match tok.next() {
            Some("v") => {
                vertices += 1;
                let c: Vec<_> = tok.collect();
                c.len() >= 3 && c.iter().all(|t| t.parse::<f32>().is_ok())
            }
            Some("vn") | Some("vt") => tok.all(|t| t.parse::<f32>().is_ok()),
            Some("f") => {
                let c: Vec<_> = tok.collect();
                c.len() >= 3
                    && c.iter().all(|t| {
                        let i = t.split('/').next().and_then(|i| i.parse::<i64>().ok());
                        i.is_some_and(|i| i != 0 && i.abs() <= vertices)
                    })
            }
            Some(word) => word.starts_with('#') || OBJ_SKIPPED.contains(&word),
            None => true,
        };
        if !ok {
            return Some((k + 1, snippet(line.trim())));
        }
    }
    None
}

pub(super) fn load_obj(path: &Path) -> Result<Raw, String> {
    let name = path.display();
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj(path, &opts).map_err(|e| match obj_bad_line(path) {
        Some((line, text)) => format!("{name}: line {line}: cannot read OBJ ({e}): '{text}'"),
        None => format!("{name}: cannot read OBJ: {e}"),
    })?;
    // The parser skips what it does not know; a line that is not OBJ is refused here.
    if let Some((line, text)) = obj_bad_line(path) {
        return Err(format!(
            "{name}: line {line}: not an OBJ statement: '{text}'"
        ));
    }
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for m in &models {
        let base = vertices.len() as u32;
        let p = &m.mesh.positions;
        vertices.extend(p.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        triangles.extend(
            m.mesh
                .indices
                .chunks_exact(3)
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
    }
    Ok((vertices, triangles))
}

/// An STL file's triangles, its corners welded where they are bit-identical (STL
/// repeats each corner in every triangle; a closed mesh written by any tool repeats
/// them exactly).
pub(super) fn load_stl(path: &Path) -> Result<Raw, String> {
    let name = path.display();
    let mut file = std::fs::File::open(path).map_err(|e| format!("{name}: {e}"))?;
    let mesh = stl_io::read_stl(&mut file)
        .map_err(|e| format!("{name}: cannot read STL (truncated, or not STL): {e}"))?;
    let vertices = mesh
        .vertices
        .iter()
        .map(|v| Vec3::new(v[0], v[1], v[2]))
        .collect();
    let triangles = mesh
        .faces
        .iter()
        .map(|f| f.vertices.map(|i| i as u32))
        .collect();
    Ok((vertices, triangles))
}

/// What a PLY file holds.
pub(super) enum Loaded {
    Mesh(Raw),
    Points(Vec<Vec3>, Vec<Vec3>),
}

/// Three scalar properties of every vertex as vectors; the error names the file, the
/// vertex and the missing property.
pub(super) fn vertex_vectors(
    verts: &[ply_rs_bw::ply::DefaultElement],
    props: [&str; 3],
    name: &impl std::fmt::Display,
) -> Result<Vec<Vec3>, String> {
    verts
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let mut c = [0.0f32; 3];
            for (k, prop) in props.iter().enumerate() {
                c[k] = e
                    .get(*prop)
                    .and_then(|p| p.to_f32_lossy())
                    .ok_or_else(|| format!("{name}: element 'vertex' {i}: no scalar '{prop}'"))?;
            }
            Ok(Vec3::from(c))
        })
        .collect()
}

pub(super) fn load_ply(path: &Path) -> Result<Loaded, String> {
    let name = path.display();
    let ply = read_ply(path)?;
    let verts = ply
        .payload
        .get("vertex")
        .ok_or_else(|| format!("{name}: no 'vertex' element"))?;
    let vertices = vertex_vectors(verts, ["x", "y", "z"], &name)?;
    let Some(faces) = ply.payload.get("face") else {
        // A point cloud: usable with normals.
        let has_normals = verts
            .first()
            .is_some_and(|e| ["nx", "ny", "nz"].iter().all(|k| e.contains_key(*k)));
        if !has_normals {
            return Err(format!(
                "{name}: no 'face' element, and no normals (nx ny nz) for an oriented point \
                 cloud: a mesh shape needs triangles or oriented points"
            ));
        }
        let normals = vertex_vectors(verts, ["nx", "ny", "nz"], &name)?;
        return Ok(Loaded::Points(vertices, normals));
    };
    let mut triangles = Vec::with_capacity(faces.len());
    for (i, f) in faces.iter().enumerate() {
        let idx = f
            .get("vertex_indices")
            .or_else(|| f.get("vertex_index"))
            .ok_or_else(|| format!("{name}: element 'face' {i}: no integer list 'vertex_indices'"))
            .and_then(|p| {
                face_indices(p).map_err(|m| format!("{name}: element 'face' {i}: {m}"))
            })?;
        if idx.len() < 3 {
            return Err(format!(
                "{name}: element 'face' {i}: {} vertices, need at least 3",
                idx.len()
            ));
        }
        for k in 1..idx.len() - 1 {
            triangles.push([idx[0], idx[k], idx[k + 1]]);
        }
    }
    Ok(Loaded::Mesh((vertices, triangles)))
}

/// A face's vertex indices from its PLY list property: a negative one is named as such
/// (indices count from 0), not as a missing list.
fn face_indices(p: &ply_rs_bw::ply::Property) -> Result<Vec<u32>, String> {
    use ply_rs_bw::ply::Property as P;
    let signed = |v: &mut dyn Iterator<Item = i64>| {
        v.map(|i| {
            u32::try_from(i).map_err(|_| {
                format!("vertex index {i} in 'vertex_indices' is negative (indices count from 0)")
            })
        })
        .collect()
    };
    match p {
        P::ListChar(v) => signed(&mut v.iter().map(|&i| i as i64)),
        P::ListShort(v) => signed(&mut v.iter().map(|&i| i as i64)),
        P::ListInt(v) => signed(&mut v.iter().map(|&i| i as i64)),
        P::ListUChar(v) => Ok(v.iter().map(|&i| i as u32).collect()),
        P::ListUShort(v) => Ok(v.iter().map(|&i| i as u32).collect()),
        P::ListUInt(v) => Ok(v.clone()),
        _ => Err("'vertex_indices' is not an integer list".to_string()),
    }
}
