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


def test_usd_stage_plays_the_run_in_pxr(cli, tmp_path):
    """`run --format usd` (with `--fixed-points` and `--phyxels`): Pixar's own reader
    (usd-core's `pxr`) opens `frames.usda`; the icosphere's Mesh prim has the input's
    642 vertices and 1,280 triangles in every sample; the points' time samples are the
    manifest's frames (time code = time × timeCodesPerSecond, the last step included),
    metres and +y up; the last sample's vertex centroid is where the run's summary puts
    the body's centre of mass (within a phyxel spacing, 1 cm); the surfel and phyxel
    Points prims keep their counts (the summary's) in every sample, and surfel i moves
    continuously (no sample jumps a point by more than the body's fall over a frame
    plus a spacing: the order is fixed)."""
    np = pytest.importorskip("numpy")
    from pxr import Usd, UsdGeom
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
    mesh.export(tmp_path / "ball.obj", file_type="obj")
    scene = tmp_path / "scene.toml"
    scene.write_text(
        "steps = 250\n[output]\nevery = 100\n"
        "[[objects]]\nname = \"ball\"\n"
        'shape = { type = "mesh", path = "ball.obj" }\n'
        "spacing = 0.01\nposition = [0.0, 0.1, 0.0]\n"
        "material = { density = 1000.0, young = 1.0e5 }\n"
    )
    out = tmp_path / "out"
    run = subprocess.run([cli, "run", str(scene), "--format", "usd", "--fixed-points",
                          "--phyxels", "--out", str(out), "--json"],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    manifest = json.loads((out / "phyxel-manifest.json").read_text())
    assert manifest["format"] == "usd" and manifest["frames"] == ["frames.usda"]
    stage = Usd.Stage.Open(str(out / "frames.usda"))
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    per_second = stage.GetTimeCodesPerSecond()
    # The manifest's dt is the f32 step in its shortest decimal form.
    assert per_second == pytest.approx(1.0 / (100 * manifest["dt"]), rel=1e-6)
    codes = [t * per_second for t in manifest["times"]]
    assert len(codes) == 4, "frames 0, 100, 200 and the last step, 250"
    ball = UsdGeom.Mesh(stage.GetPrimAtPath("/World/ball"))
    points = ball.GetPointsAttr()
    assert points.GetTimeSamples() == pytest.approx(codes)
    assert stage.GetStartTimeCode() == 0 and stage.GetEndTimeCode() == pytest.approx(codes[-1])
    assert len(ball.GetFaceVertexCountsAttr().Get()) == len(mesh.faces)
    for code in codes:
        assert len(points.Get(code)) == len(mesh.vertices)
    last = np.asarray(points.Get(codes[-1]))
    body = summary["bodies"][0]
    assert np.linalg.norm(last.mean(axis=0) - np.asarray(body["com"])) < 0.01
    assert last[:, 1].mean() < 0.1 - 0.01, "the ball fell"
    for name, count in [("ball_surfels", body["surfels"]), ("ball_phyxels", body["phyxels"])]:
        prim = UsdGeom.Points(stage.GetPrimAtPath(f"/World/{name}"))
        samples = [np.asarray(prim.GetPointsAttr().Get(c)) for c in codes]
        assert all(len(s) == count for s in samples), name
        assert len(prim.GetWidthsAttr().Get(codes[0])) == count
        for a, b in zip(samples, samples[1:]):
            fall = np.linalg.norm(a.mean(axis=0) - b.mean(axis=0))
            assert np.linalg.norm(a - b, axis=1).max() < fall + 0.01, name


BLENDER_READ = r'''
import bpy, json, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
assert bpy.ops.wm.usd_import(filepath=sys.argv[1]) == {"FINISHED"}
scene = bpy.context.scene
out = {"version": bpy.app.version_string, "frame_end": scene.frame_end, "objects": {}}
for o in bpy.data.objects:
    if o.type in ("MESH", "POINTCLOUD"):
        out["objects"][o.name] = {"type": o.type, "modifiers": [m.type for m in o.modifiers]}
centroids = []
for frame in (scene.frame_start, scene.frame_end):
    scene.frame_set(frame)
    ev = bpy.data.objects["left"].evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = ev.to_mesh()
    n = len(mesh.vertices)
    c = [sum((ev.matrix_world @ v.co)[k] for v in mesh.vertices) / n for k in range(3)]
    centroids.append({"frame": frame, "vertices": n, "faces": len(mesh.polygons), "centroid": c})
    ev.to_mesh_clear()
out["left"] = centroids
print("BLENDER " + json.dumps(out))
'''


def test_blender_imports_the_usd_stage_as_animation(cli, tmp_path):
    """Blender itself (the `bpy` wheel, in the Python of $PHYXEL_BPY_PYTHON, a venv of
    its own: CI installs it where a wheel exists for the machine) imports
    `run two-spheres --format usd --fixed-points`: each sphere a mesh and its surfels a
    point cloud, animated by a mesh sequence cache; one Blender frame per time code (0
    to the last frame); the left sphere's mesh has the same vertex and face counts at
    its first and last frame, starts where the scene puts it (x = −0.15 m) and ends
    where the run's summary puts its centre of mass (within 1 cm: vertices sample the
    surface, the mass the volume)."""
    import os
    python = os.environ.get("PHYXEL_BPY_PYTHON")
    if not python:
        pytest.skip("no Blender Python: set PHYXEL_BPY_PYTHON to a venv's python with bpy")
    np = pytest.importorskip("numpy")
    out = tmp_path / "out"
    run = subprocess.run([cli, "run", "two-spheres", "--steps", "120", "--format", "usd",
                          "--fixed-points", "--out", str(out), "--json"],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    frames = len(json.loads((out / "phyxel-manifest.json").read_text())["times"])
    script = tmp_path / "read.py"
    script.write_text(BLENDER_READ)
    blender = subprocess.run([python, str(script), str(out / "frames.usda")],
                             capture_output=True, text=True, timeout=600)
    assert blender.returncode == 0, blender.stderr[-2000:]
    line = [l for l in blender.stdout.splitlines() if l.startswith("BLENDER ")][-1]
    got = json.loads(line.removeprefix("BLENDER "))
    objects = got["objects"]
    for name, kind in [("left", "MESH"), ("right", "MESH"),
                       ("left_surfels", "POINTCLOUD"), ("right_surfels", "POINTCLOUD")]:
        assert objects[name]["type"] == kind, (name, objects)
        assert "MESH_SEQUENCE_CACHE" in objects[name]["modifiers"], (name, objects)
    assert got["frame_end"] == frames - 1
    first, last = got["left"]
    assert first["vertices"] == last["vertices"] > 0 and first["faces"] == last["faces"] > 0
    assert first["centroid"] == pytest.approx([-0.15, 0.0, 0.0], abs=1e-3)
    com = np.asarray(summary["bodies"][0]["com"])
    assert np.linalg.norm(np.asarray(last["centroid"]) - com) < 0.01, (last, com)
