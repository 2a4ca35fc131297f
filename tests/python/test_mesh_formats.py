"""Meshes written by trimesh, a reader/writer users' pipelines use, load as shapes: an
icosphere exported as binary and as ASCII STL, and as OBJ and PLY, runs through
`phyxel run`, and its body's mass matches density × the mesh's own volume (trimesh's,
an independent computation) within 5% (phyxels on a 5 mm lattice in a 5 cm sphere:
the lattice's boundary layer is the error)."""

import json
import subprocess

import pytest

trimesh = pytest.importorskip("trimesh")


@pytest.mark.parametrize("name,file_type", [
    ("ball.stl", "stl"),
    ("ball_ascii.stl", "stl_ascii"),
    ("ball.obj", "obj"),
    ("ball.ply", "ply"),
])
def test_trimesh_exports_load_with_the_mesh_volume(cli, tmp_path, name, file_type):
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    mesh.export(tmp_path / name, file_type=file_type)
    scene = tmp_path / "scene.toml"
    scene.write_text(
        "[[objects]]\n"
        f'shape = {{ type = "mesh", path = "{name}" }}\n'
        "spacing = 0.005\n"
        "material = { density = 1000.0 }\n"
    )
    out = subprocess.run([cli, "run", str(scene), "--steps", "1", "--json"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    body = json.loads(out.stdout)["bodies"][0]
    want = 1000.0 * mesh.volume
    assert abs(body["mass"] / want - 1.0) < 0.05, (body["mass"], want)


@pytest.mark.parametrize("fmt", ["ply", "vtk"])
def test_mesh_frames_keep_the_input_mesh_and_follow_the_body(cli, tmp_path, fmt):
    """`run --mesh`: an icosphere OBJ (642 vertices, 1,280 triangles) falling comes back as `mesh_NNNNN` frames that trimesh (PLY) and pyvista (VTK) read
    with the input's vertex and face counts, the first frame with the input's vertices
    (centred, then placed at the scene's position) and triangles (area and outward
    volume), and the last
    frame's vertex centroid where the run's summary puts the body's centre of mass
    (within a phyxel spacing: vertices follow the surface, the mass the volume)."""
    np = pytest.importorskip("numpy")
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    mesh.export(tmp_path / "ball.obj", file_type="obj")
    source = trimesh.load(tmp_path / "ball.obj", process=False)
    scene = tmp_path / "scene.toml"
    scene.write_text(
        "steps = 300\n[output]\nevery = 100\n"
        "[[objects]]\nname = \"ball\"\n"
        'shape = { type = "mesh", path = "ball.obj" }\n'
        "spacing = 0.01\nposition = [0.0, 0.1, 0.0]\n"
        "material = { density = 1000.0, young = 1.0e5 }\n"
    )
    out = tmp_path / "out"
    run = subprocess.run([cli, "run", str(scene), "--mesh", "--format", fmt, "--out", str(out),
                          "--json"], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    ext = "ply" if fmt == "ply" else "vtp"
    manifest = json.loads((out / "phyxel-manifest.json").read_text())
    names = [f"mesh_{k:05}.{ext}" for k in range(4)]
    assert all(n in manifest["frames"] for n in names)
    frames = []
    for n in names:
        if fmt == "ply":
            m = trimesh.load(out / n, process=False)
            frames.append((np.asarray(m.vertices), np.asarray(m.faces)))
        else:
            pv = pytest.importorskip("pyvista")
            m = pv.read(str(out / n))
            frames.append((np.asarray(m.points), np.asarray(m.faces).reshape(-1, 4)[:, 1:]))
    centred = np.asarray(source.vertices) - 0.5 * (source.bounds[0] + source.bounds[1])
    for vertices, faces in frames:
        assert vertices.shape == source.vertices.shape
        assert faces.shape == source.faces.shape
    # The OBJ reader may number the vertices in the order the faces first use them: the
    # same vertex set, and the same triangles (their total area and enclosed volume).
    rows = lambda v: v[np.lexsort(v.T[::-1])]
    assert np.allclose(rows(frames[0][0]), rows(centred + [0.0, 0.1, 0.0]), atol=1e-6)
    first = trimesh.Trimesh(frames[0][0], frames[0][1], process=False)
    assert first.area == pytest.approx(source.area, rel=1e-5)
    assert first.volume == pytest.approx(source.volume, rel=1e-5)
    com = np.asarray(summary["bodies"][0]["com"])
    assert np.linalg.norm(frames[-1][0].mean(axis=0) - com) < 0.01
    assert frames[-1][0][:, 1].mean() < 0.1 - 0.01, "the ball fell"



def test_primitive_meshes_are_closed_and_follow_their_bodies(cli, tmp_path):
    """`run two-spheres --mesh --format vtk` through the impact: pyvista reads each frame's
    mesh as one closed surface per sphere (no open edge), and each sphere's vertex
    centroid lies within a phyxel spacing (2.5 cm) of its centre of mass in the summary."""
    np = pytest.importorskip("numpy")
    pv = pytest.importorskip("pyvista")
    out = tmp_path / "out"
    run = subprocess.run([cli, "run", "two-spheres", "--steps", "150", "--mesh", "--format",
                          "vtk", "--out", str(out), "--json"], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    mesh = pv.read(str(out / "mesh_00015.vtp"))
    assert mesh.n_cells > 1000 and mesh.n_open_edges == 0
    objects = np.asarray(mesh.point_data["object"])
    for body in summary["bodies"]:
        points = np.asarray(mesh.points)[objects == body["id"]]
        assert len(points) > 100
        assert np.linalg.norm(points.mean(axis=0) - np.asarray(body["com"])) < 0.025
