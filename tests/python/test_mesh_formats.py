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
