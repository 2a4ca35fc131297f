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


def test_fixed_points_keep_count_and_order_through_contact(cli, tmp_path):
    """`run --fixed-points`: through the `two-spheres` impact, every `.vtp` frame that
    ParaView's reader (pyvista) plays holds the same points in the same order (the
    summary's surfel count, the same `object` column), the colliding ones flagged
    `contact`; the render surface of the same run changes its count, so the check can
    tell the two apart."""
    np = pytest.importorskip("numpy")
    counts = {}
    for mode in ["render", "fixed"]:
        out = tmp_path / mode
        args = [cli, "run", "two-spheres", "--steps", "150", "--format", "vtk", "--out",
                str(out), "--json"] + (["--fixed-points"] if mode == "fixed" else [])
        run = subprocess.run(args, capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stderr
        summary = json.loads(run.stdout)
        manifest = json.loads((out / "phyxel-manifest.json").read_text())
        assert manifest["surfels"] == mode
        reader = pv.PVDReader(str(out / "frames.pvd"))
        frames = []
        for t in reader.time_values:
            reader.set_active_time_value(t)
            frames.append(reader.read()[0])
        counts[mode] = [f.n_points for f in frames]
        if mode == "fixed":
            assert counts[mode] == [summary["surfels"]] * len(frames)
            objects = np.asarray(frames[0].point_data["object"])
            flagged = 0
            for f in frames:
                assert np.array_equal(np.asarray(f.point_data["object"]), objects)
                flagged += int(np.asarray(f.point_data["contact"]).sum())
            assert flagged > 0, "the spheres collide within 150 steps"
            # Point i moves with its sphere: the left sphere's points all moved right.
            left = objects == objects[0]
            dx = np.asarray(frames[-1].points)[left, 0] - np.asarray(frames[0].points)[left, 0]
            assert dx.min() > 0
    assert len(set(counts["render"])) > 1, counts["render"]


def test_phyxel_frames_show_the_stress_where_the_cantilever_is_loaded(cli, tmp_path):
    """`run --phyxels --format vtk` on the cantilever (`mls-implicit`, 60 steps of 1/60 s:
    settled): ParaView's reader finds the phyxels as part 2 of `frames.pvd` with
    displacement, six-component strain and stress and `von_mises`. Reference:
    Euler–Bernoulli's bending moment `q (L − s)² / 2` (s from the clamp at x = −0.45 m,
    L = 0.95 m) is over 20 times larger within 0.15 m of the clamp than within 0.15 m of
    the tip; the test asks 5 times (the surface layers and shear blur a ratio of means),
    and a tip that moved down more than the clamp."""
    np = pytest.importorskip("numpy")
    out = tmp_path / "out"
    run = subprocess.run([cli, "run", "cantilever", "--backend", "mls-implicit", "--steps",
                          "60", "--phyxels", "--format", "vtk", "--out", str(out), "--json"],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    reader = pv.PVDReader(str(out / "frames.pvd"))
    reader.set_active_time_value(reader.time_values[-1])
    phyxels = reader.read()[2]
    assert phyxels.n_points == summary["phyxels"]
    for name, width in [("displacement", 3), ("strain", 6), ("stress", 6)]:
        assert phyxels.point_data[name].shape == (phyxels.n_points, width)
    x = np.asarray(phyxels.points)[:, 0]
    vm = np.asarray(phyxels.point_data["von_mises"])
    clamp, tip = x < -0.30, x > 0.30
    assert vm[clamp].mean() > 5 * vm[tip].mean() > 0
    sag = np.asarray(phyxels.point_data["displacement"])[:, 1]
    assert sag[tip].mean() < sag[clamp].mean() <= 0.0
