"""`phyxel run --format vtk --out DIR` as ParaView's readers see it (through pyvista and
VTK, the readers users open it with): `frames.pvd` plays the frames at the manifest's
times, the last step included, and each `.vtp` frame holds the summary's surfel
count with the documented point data."""

import json
import subprocess

import pytest

pv = pytest.importorskip("pyvista")


def test_vtk_series_opens_with_times(cli, tmp_path):
    out = tmp_path / "out"
    run = subprocess.run([cli, "run", "falling-sphere", "--steps", "25", "--format", "vtk",
                          "--out", str(out), "--json"], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    manifest = json.loads((out / "phyxel-manifest.json").read_text())
    assert "frames.pvd" in manifest["frames"]
    reader = pv.PVDReader(str(out / "frames.pvd"))
    # falling-sphere writes every 10 steps: steps 0, 10, 20 and the last, 25.
    assert len(reader.time_values) == 4
    assert reader.time_values == pytest.approx(manifest["times"], rel=1e-12, abs=1e-15)
    assert reader.time_values[-1] == pytest.approx(25 * manifest["dt"], rel=1e-5)
    reader.set_active_time_value(reader.time_values[-1])
    blocks = reader.read()
    surfels = blocks[0]
    assert surfels.n_points == summary["surfels"]
    for name in ["Normals", "radius", "object", "contact"]:
        assert name in surfels.point_data.keys()


def test_binary_vtp_matches_the_ply_frame_and_is_smaller(cli, tmp_path):
    """The same run written as `.vtp` (binary, zlib) and as PLY: pyvista's VTK reader and
    trimesh's PLY reader see the same positions, bit for bit, and the `.vtp` is no
    larger."""
    np = pytest.importorskip("numpy")
    trimesh = pytest.importorskip("trimesh")
    frames = {}
    for fmt in ["vtk", "ply"]:
        out = tmp_path / fmt
        run = subprocess.run([cli, "run", "two-spheres", "--steps", "100", "--format", fmt,
                              "--out", str(out)], capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr
        frames[fmt] = out / ("surfels_00010." + ("vtp" if fmt == "vtk" else "ply"))
    vtp = pv.read(str(frames["vtk"]))
    ply = trimesh.load(str(frames["ply"]))
    assert vtp.n_points == len(ply.vertices) > 0
    assert vtp.n_cells == vtp.n_points
    assert np.array_equal(np.asarray(vtp.points, dtype=np.float32),
                          np.asarray(ply.vertices, dtype=np.float32))
    assert frames["vtk"].stat().st_size <= frames["ply"].stat().st_size
