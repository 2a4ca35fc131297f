"""The README's mesh picture, drawn by PyVista (VTK), not by phyxel: a soft ellipsoid
given as an OBJ mesh dropped on a plane (`mls-implicit`, 1 s at 1/120 s), written with `run --mesh --format vtk`, and
the last frame's `mesh_NNNNN.vtp` (the OBJ's own triangles, moved with the body)
rendered off-screen with the ground and the frame's contact surfels.

    python docs/gallery/mesh.py [PHYXEL_BIN]   # needs trimesh and pyvista; a display
                                               # or xvfb-run
"""

import json
import pathlib
import subprocess
import sys
import tempfile

import pyvista as pv
import trimesh

root = pathlib.Path(__file__).resolve().parents[2]
phyxel = sys.argv[1] if len(sys.argv) > 1 else str(root / "target/release/phyxel")
work = pathlib.Path(tempfile.mkdtemp())
ellipsoid = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
ellipsoid.apply_scale([0.12, 0.07, 0.09])
ellipsoid.export(work / "ellipsoid.obj")
(work / "scene.toml").write_text(
    'steps = 120\n[output]\nevery = 120\n'
    '[[objects]]\nname = "ground"\nstatic = true\n'
    'shape = { type = "box", size = [0.6, 0.05, 0.6] }\nspacing = 0.025\n'
    'position = [0.0, -0.125, 0.0]\n'
    '[[objects]]\nname = "ellipsoid"\n'
    'shape = { type = "mesh", path = "ellipsoid.obj" }\nspacing = 0.015\n'
    'backend = "mls-implicit"\n'
    'position = [0.0, -0.012, 0.0]\nrotation = [0.0, 0.0, 25.0]\n'
    'material = { young = 2.0e4, poisson = 0.4 }\n'
)
out = work / "out"
subprocess.run([phyxel, "run", str(work / "scene.toml"), "--mesh", "--format", "vtk",
                "--out", str(out)], check=True)
manifest = json.loads((out / "phyxel-manifest.json").read_text())
last = sorted(f for f in manifest["frames"] if f.startswith("mesh_"))[-1]
contacts = "contacts_" + last.removeprefix("mesh_")
mesh = pv.read(out / last)

pv.OFF_SCREEN = True
plot = pv.Plotter(window_size=(640, 400))
plot.set_background("white")
body = mesh.threshold([1, 1], scalars="object")
ground = mesh.threshold([0, 0], scalars="object")
plot.add_mesh(ground, color="#d9d9d9")
plot.add_mesh(body, color="#4a90c2", smooth_shading=True, show_edges=True,
              edge_color="#27587a", line_width=0.5)
touch = pv.read(out / contacts)
if touch.n_points:
    plot.add_points(touch, color="#d62728", point_size=3, render_points_as_spheres=True)
plot.camera_position = [(0.32, 0.06, 0.4), (0.0, -0.07, 0.0), (0.0, 1.0, 0.0)]
target = root / "docs/gallery/mesh-ellipsoid.png"
plot.screenshot(str(target))
print(f"wrote {target} from {last}")
