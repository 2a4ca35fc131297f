//! Frame export and import: PLY round trip, VTK (.vtp) export, bad-input errors.

use phyxel::io::frame::{Format, Frame};
use phyxel::io::import::read_frame;
use phyxel::scene::Scene;
use phyxel::world::output::surface_frame;
use std::process::Command;

use crate::common;
use common::TempDir;

/// The render surface of two-spheres mid-collision (contact surfels present).
fn colliding_frame() -> Frame {
    let scene = Scene::builtin("two-spheres").unwrap();
    let mut world = scene.build(&Default::default()).unwrap();
    world.render_contacts = true;
    for _ in 0..150 {
        world.step();
    }
    surface_frame(&world)
}

/// PLY round trip: the render surface of `two-spheres` after 150 steps (more than 1000
/// points, contact surfels and both objects present) written as PLY and read back equals
/// the frame exactly (every position, normal, radius, object id and contact flag).
#[test]
fn ply_round_trip_is_exact() {
    let dir = TempDir::new("import", "ply");
    let frame = colliding_frame();
    assert!(frame.len() > 1000);
    assert!(
        frame.contact.contains(&1),
        "two-spheres at step 150 is in contact"
    );
    assert!(frame.object.contains(&1));
    let path = dir.0.join("f.ply");
    frame.write(&path, Format::Ply).unwrap();
    let back = read_frame(&path).unwrap();
    assert_eq!(back, frame);
}

/// `phyxel run falling-sphere --steps 10 --out DIR`: the frame `surfels_00001.ply` read
/// back equals exactly the render surface of the same scene stepped 10 times through the
/// library (contact surfels rendered).
#[test]
fn run_out_frames_read_back() {
    let dir = TempDir::new("import", "run");
    let o = Command::new(env!("CARGO_BIN_EXE_phyxel"))
        .args(["run", "falling-sphere", "--steps", "10", "--out"])
        .arg(&dir.0)
        .output()
        .unwrap();
    assert!(o.status.success());
    let f = read_frame(&dir.0.join("surfels_00001.ply")).unwrap();
    let scene = Scene::builtin("falling-sphere").unwrap();
    let mut world = scene.build(&Default::default()).unwrap();
    world.render_contacts = true;
    for _ in 0..10 {
        world.step();
    }
    assert_eq!(f, surface_frame(&world));
}

/// The bytes of one array of a binary `.vtp` file, decoded as VTK's format says
/// (independently of the writer): the `<DataArray>` after `key` (`Name="radius"`, or
/// `<Points>` for the positions) gives its offset into the appended data, where a UInt64
/// header (block count, block size, last partial block's size, compressed sizes)
/// precedes the zlib blocks.
fn vtp_array(bytes: &[u8], key: &str) -> Vec<u8> {
    use std::io::Read;
    let find = |hay: &[u8], needle: &[u8]| hay.windows(needle.len()).position(|w| w == needle);
    let appended = find(bytes, b"<AppendedData encoding=\"raw\">").expect("appended data");
    let header = std::str::from_utf8(&bytes[..appended]).expect("an XML header");
    let data = appended + find(&bytes[appended..], b"_").expect("the data's mark") + 1;
    // A name is inside its array's tag; an element's array follows it.
    let mut tag = &header[header.find(key).expect(key)..];
    if key.starts_with('<') {
        tag = &tag[tag.find("<DataArray").expect("an array")..];
    }
    let offset: usize = tag[tag.find("offset=\"").unwrap() + 8..]
        .split('"')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let word = |k: usize| {
        let at = data + offset + 8 * k;
        u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize
    };
    let (blocks, size, last) = (word(0), word(1), word(2));
    let mut at = data + offset + 8 * (3 + blocks);
    let mut out = Vec::new();
    for b in 0..blocks {
        let len = word(3 + b);
        let mut raw = Vec::new();
        flate2::read::ZlibDecoder::new(&bytes[at..at + len])
            .read_to_end(&mut raw)
            .unwrap();
        let expected = if b + 1 == blocks && last > 0 {
            last
        } else {
            size
        };
        assert_eq!(raw.len(), expected, "block {b} of {key}");
        out.extend_from_slice(&raw);
        at += len;
    }
    out
}

fn f32s(bytes: &[u8]) -> Vec<f32> {
    bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// VTK export of the colliding `two-spheres` frame: a binary `.vtp` file declaring the
/// frame's point count, whose `radius`, `object`, `contact`, `Normals` and point arrays,
/// decoded by VTK's format description, equal the frame's values bit for bit, with one
/// vertex cell per point; and smaller than the PLY of the same frame.
#[test]
fn vtk_export_has_the_same_point_data() {
    let dir = TempDir::new("import", "vtk");
    let frame = colliding_frame();
    let path = dir.0.join("f.vtp");
    frame.write(&path, Format::Vtk).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]).to_string();
    assert!(head.starts_with("<?xml"));
    assert!(head.contains(&format!("NumberOfPoints=\"{}\"", frame.len())));
    let radius = f32s(&vtp_array(&bytes, "Name=\"radius\""));
    let object: Vec<i32> = vtp_array(&bytes, "Name=\"object\"")
        .chunks_exact(4)
        .map(|c| i32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    let contact = vtp_array(&bytes, "Name=\"contact\"");
    let normals = f32s(&vtp_array(&bytes, "Name=\"Normals\""));
    let points = f32s(&vtp_array(&bytes, "<Points>"));
    let connectivity = vtp_array(&bytes, "Name=\"connectivity\"");
    assert_eq!(radius.len(), frame.len());
    assert_eq!(normals.len(), 3 * frame.len());
    assert_eq!(connectivity.len(), 8 * frame.len());
    for i in 0..frame.len() {
        assert_eq!(radius[i].to_bits(), frame.radius[i].to_bits());
        assert_eq!(object[i], frame.object[i]);
        assert_eq!(contact[i], frame.contact[i]);
        assert_eq!(normals[3 * i..3 * i + 3], frame.normal[i].to_array());
        assert_eq!(points[3 * i..3 * i + 3], frame.pos[i].to_array());
    }
    let ply = dir.0.join("f.ply");
    frame.write(&ply, Format::Ply).unwrap();
    let (vtp_size, ply_size) = (bytes.len(), std::fs::metadata(&ply).unwrap().len() as usize);
    assert!(
        vtp_size <= ply_size,
        "{vtp_size} bytes against the PLY's {ply_size}"
    );
}

/// `phyxel run falling-sphere --steps 10 --format vtk --out DIR` writes the first two
/// frames as complete `.vtp` files (a `PolyData` VTKFile, closed by `</VTKFile>`), no
/// `surfels_00000.ply`, and `frames.pvd` naming them (tests/python/test_frame_readers.py
/// opens it with pyvista); `--format obj` is refused.
#[test]
fn run_format_vtk_writes_vtp_frames() {
    let dir = TempDir::new("import", "runvtk");
    let o = Command::new(env!("CARGO_BIN_EXE_phyxel"))
        .args([
            "run",
            "falling-sphere",
            "--steps",
            "10",
            "--format",
            "vtk",
            "--out",
        ])
        .arg(&dir.0)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for k in 0..=1 {
        let p = dir.0.join(format!("surfels_{k:05}.vtp"));
        let bytes = std::fs::read(&p).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("<VTKFile type=\"PolyData\""));
        assert!(text.trim_end().ends_with("</VTKFile>"));
    }
    assert!(!dir.0.join("surfels_00000.ply").exists());
    // The collection names each frame's files at its time (frame 1: step 10).
    let pvd = std::fs::read_to_string(dir.0.join("frames.pvd")).unwrap();
    assert!(pvd.contains("type=\"Collection\""), "{pvd}");
    assert!(
        pvd.contains("part=\"0\" file=\"surfels_00001.vtp\"")
            && pvd.contains("part=\"1\" file=\"contacts_00001.vtp\""),
        "{pvd}"
    );
    let o = Command::new(env!("CARGO_BIN_EXE_phyxel"))
        .args(["run", "falling-sphere", "--format", "obj"])
        .output()
        .unwrap();
    assert!(!o.status.success());
}

/// A binary PLY frame cut after 10 whole vertices (33 bytes each) and 5 bytes of the 11th
/// is an error naming the file, the element (`element 'vertex' 10 of` …) and that the
/// data is cut short.
#[test]
fn truncated_binary_ply_names_file_and_element() {
    let dir = TempDir::new("import", "trunc");
    let frame = colliding_frame();
    let path = dir.0.join("cut.ply");
    frame.write_ply(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    // Keep the header and a bit over 10 vertices (33 bytes each).
    let header = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    std::fs::write(&path, &bytes[..header + 33 * 10 + 5]).unwrap();
    let err = read_frame(&path).unwrap_err();
    assert!(err.contains("cut.ply"), "{err}");
    assert!(err.contains("element 'vertex' 10 of"), "{err}");
    assert!(err.contains("cut short"), "{err}");
}

/// Reading bad frames gives errors naming the file: a missing file (`cannot open`), a
/// text file that is not PLY (`not a PLY file`, quoting its first line), a NaN coordinate in a binary frame (`'vertex' 1`
/// … `not finite`), a `nan` in an ASCII frame (the parser's `Line 9`), and an ASCII frame
/// with fewer values than its header declares (`vertex`).
#[test]
fn missing_and_malformed_frames_are_errors() {
    let dir = TempDir::new("import", "bad");
    let err = read_frame(&dir.0.join("none.ply")).unwrap_err();
    assert!(
        err.contains("none.ply") && err.contains("cannot open"),
        "{err}"
    );
    let p = dir.0.join("text.ply");
    std::fs::write(&p, "not a ply file\n").unwrap();
    let err = read_frame(&p).unwrap_err();
    assert!(
        err.contains("text.ply") && err.contains("not a PLY file: it starts with 'not a ply file'"),
        "{err}"
    );
    // NaN in a binary frame: the element is named.
    let mut f = Frame::default();
    f.push(glam::Vec3::ZERO, glam::Vec3::Z, 0.1, 0, 0);
    f.push(
        glam::Vec3::new(1.0, f32::NAN, 0.0),
        glam::Vec3::Z,
        0.1,
        0,
        0,
    );
    let p = dir.0.join("nan.ply");
    f.write_ply(&p).unwrap();
    let err = read_frame(&p).unwrap_err();
    assert!(
        err.contains("nan.ply") && err.contains("'vertex' 1") && err.contains("not finite"),
        "{err}"
    );
    // In ASCII the parser refuses "nan" with the line number.
    let p = dir.0.join("nan_ascii.ply");
    std::fs::write(
        &p,
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
         property float z\nend_header\n0 0 0\n1 nan 0\n",
    )
    .unwrap();
    let err = read_frame(&p).unwrap_err();
    assert!(
        err.contains("nan_ascii.ply") && err.contains("Line 9"),
        "{err}"
    );
    let p = dir.0.join("short.ply");
    std::fs::write(
        &p,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nend_header\n0 0 0\n1 1\n",
    )
    .unwrap();
    let err = read_frame(&p).unwrap_err();
    assert!(err.contains("short.ply") && err.contains("vertex"), "{err}");
}

/// Data after the declared elements is an error (the header's counts do not match the
/// data, and a reader stopping there would drop points silently), binary and ASCII;
/// trailing white space in ASCII is not.
#[test]
fn data_after_the_declared_elements_is_an_error() {
    let dir = TempDir::new("import", "extra");
    let mut f = Frame::default();
    f.push(glam::Vec3::ZERO, glam::Vec3::Z, 0.1, 0, 0);
    let p = dir.0.join("extra.ply");
    f.write_ply(&p).unwrap();
    assert_eq!(read_frame(&p).unwrap().len(), 1);
    let mut bytes = std::fs::read(&p).unwrap();
    bytes.extend_from_slice(&[0; 33]); // one more vertex than declared
    std::fs::write(&p, &bytes).unwrap();
    let err = read_frame(&p).unwrap_err();
    assert!(
        err.contains("extra.ply") && err.contains("33 bytes after") && err.contains("1 'vertex'"),
        "{err}"
    );
    let ascii = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                 property float z\nend_header\n0 0 0\n";
    let p = dir.0.join("ascii.ply");
    std::fs::write(&p, format!("{ascii}\n  \n")).unwrap();
    assert_eq!(
        read_frame(&p).unwrap().len(),
        1,
        "trailing white space is fine"
    );
    std::fs::write(&p, format!("{ascii}1 2 3\n")).unwrap();
    let err = read_frame(&p).unwrap_err();
    assert!(
        err.contains("ascii.ply") && err.contains("\"1 2 3\"") && err.contains("counts"),
        "{err}"
    );
}

/// A frame vertex with a negative or infinite disk radius, or a NaN normal, is an error
/// naming the file and the vertex (the renderer would draw nothing for them, silently).
#[test]
fn bad_radius_or_normal_in_a_frame_is_an_error() {
    let dir = TempDir::new("import", "radius");
    for (name, normal, radius, want) in [
        (
            "neg",
            glam::Vec3::Z,
            -1.0,
            "'vertex' 1: radius -1 must be finite and >= 0",
        ),
        (
            "inf",
            glam::Vec3::Z,
            f32::INFINITY,
            "'vertex' 1: radius inf must be",
        ),
        (
            "nan-normal",
            glam::Vec3::new(0.0, f32::NAN, 1.0),
            0.1,
            "'vertex' 1: normal",
        ),
    ] {
        let mut f = Frame::default();
        f.push(glam::Vec3::ZERO, glam::Vec3::Z, 0.1, 0, 0);
        f.push(glam::Vec3::X, normal, radius, 0, 0);
        let p = dir.0.join(format!("{name}.ply"));
        f.write_ply(&p).unwrap();
        let err = read_frame(&p).unwrap_err();
        assert!(
            err.contains(&format!("{name}.ply")) && err.contains(want),
            "{err}"
        );
    }
    let mut f = Frame::default();
    f.push(glam::Vec3::ZERO, glam::Vec3::Z, 0.0, 0, 0);
    let p = dir.0.join("zero.ply");
    f.write_ply(&p).unwrap();
    assert_eq!(read_frame(&p).unwrap().len(), 1, "radius 0 means unknown");
}

/// Phyxel frames carry mechanics: a box stretched uniformly by `F = diag(1.02, 1, 1)`
/// and stepped once (dt 1e-7 s, no gravity: it barely moves) gives every phyxel the
/// closed forms (MLS gradients are exact for affine fields): Green–Lagrange
/// `E_xx = ½(1.02² − 1) = 0.0202`, the Saint Venant–Kirchhoff stress
/// `S = λ tr(E) I + 2μ E` and its von Mises value `|S_xx − S_yy|`, and the displacement
/// `0.02 x₀`. Tolerance 1e-3 relative (f32 positions); the PLY names the columns.
#[test]
fn phyxel_frames_carry_strain_and_stress_of_a_uniform_stretch() {
    use phyxel::world::output::phyxel_frame;
    let text = r#"
        name = "stretch"
        gravity = [0.0, 0.0, 0.0]
        dt = 1e-7
        [[objects]]
        name = "box"
        shape = { type = "box", size = [0.1, 0.1, 0.1] }
        spacing = 0.02
        material = { young = 1.0e5, poisson = 0.3 }
    "#;
    let mut world = Scene::parse(text, "in-code")
        .unwrap()
        .build(&Default::default())
        .unwrap();
    let p = &mut world.objects[0].phyxels;
    for i in 0..p.len() {
        let x = p.rest.get(i);
        p.pos.set(i, glam::Vec3::new(1.02 * x.x, x.y, x.z));
    }
    world.step();
    let f = phyxel_frame(&world);
    let (lambda, mu) = world.objects[0].material.lame();
    let exx = 0.5 * (1.02f32 * 1.02 - 1.0);
    let (sxx, syy) = (lambda * exx + 2.0 * mu * exx, lambda * exx);
    let close = |a: f32, b: f32, scale: f32| (a - b).abs() <= 1e-3 * scale;
    assert!(f.pos.len() > 100);
    for i in 0..f.pos.len() {
        let (e, s) = (f.strain[i], f.stress[i]);
        assert!(close(e[0], exx, exx), "phyxel {i}: strain {e:?}");
        assert!(
            e[1..].iter().all(|&c| close(c, 0.0, exx)),
            "phyxel {i}: strain {e:?}"
        );
        assert!(close(s[0], sxx, sxx) && close(s[1], syy, sxx) && close(s[2], syy, sxx));
        assert!(
            s[3..].iter().all(|&c| close(c, 0.0, sxx)),
            "phyxel {i}: stress {s:?}"
        );
        assert!(
            close(f.von_mises[i], sxx - syy, sxx),
            "phyxel {i}: {}",
            f.von_mises[i]
        );
        let x0 = world.objects[0].phyxels.rest.get(i);
        assert!(
            (f.displacement[i].x - 0.02 * x0.x).abs() < 1e-5,
            "phyxel {i}"
        );
    }
    let dir = TempDir::new("import", "mechanics");
    let path = dir.0.join("p.ply");
    f.write(&path, Format::Ply).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let end = bytes.windows(10).position(|w| w == b"end_header").unwrap();
    let head = String::from_utf8_lossy(&bytes[..end]);
    for name in ["ux", "strain_xx", "stress_zx", "von_mises"] {
        assert!(head.contains(&format!("property float {name}\n")), "{head}");
    }
}
