"""`phyxel.World` and `phyxel.Body`: stepping, NumPy arrays, writes between steps,
contact patches, summaries equal to the CLI's, frames, pictures and errors.

References: the CLI's `run --json` (the same engine through another door: bitwise equal
summaries, wall times aside), Newton's laws for writes (a free body moves by v·dt, a
force F changes velocity by F dt / m) and momentum conservation through a collision."""

import json
import subprocess
import signal
import threading
import time

import numpy as np
import pytest

import phyxel

WALL = ("wall_seconds", "steps_per_second", "phase_seconds")


def strip(summary):
    return {k: v for k, v in summary.items() if k not in WALL}


@pytest.mark.parametrize("scene,steps", [("two-spheres", 200), ("pile", 120), ("plastic-fracture", 300)])
def test_summary_equals_cli_run_json(cli, scene, steps):
    out = subprocess.run([cli, "run", scene, "--steps", str(steps), "--json"], capture_output=True, check=True)
    expected = strip(json.loads(out.stdout))
    assert strip(phyxel.run(scene, steps=steps)) == expected
    w = phyxel.Scene.builtin(scene).build()
    w.step(steps)
    assert strip(w.summary()) == expected


def test_arrays_have_engine_shapes_and_dtypes_and_are_read_only():
    w = phyxel.Scene.builtin("two-spheres").build()
    b = w["left"]
    s = w.summary()["bodies"][0]
    n, m = s["phyxels"], s["surfels"]
    for name, shape in [
        ("phyxel_positions", (n, 3)),
        ("phyxel_velocities", (n, 3)),
        ("phyxel_forces", (n, 3)),
        ("phyxel_masses", (n,)),
        ("surfel_positions", (m, 3)),
        ("surfel_normals", (m, 3)),
        ("surfel_radii", (m,)),
    ]:
        a = getattr(b, name)
        assert a.shape == shape and a.dtype == np.float32, name
        with pytest.raises(ValueError):
            a[0] = 0
    assert b.mass == pytest.approx(float(b.phyxel_masses.astype(np.float64).sum()), rel=1e-6)
    assert np.allclose(np.linalg.norm(b.surfel_normals, axis=1), 1, atol=1e-4)


def test_bodies_by_index_name_and_id():
    w = phyxel.Scene.builtin("pile").build()
    names = [b.name for b in w.objects]
    assert len(w) == len(names)
    assert w[0].name == names[0] and w[-1].name == names[-1]
    assert w[names[2]].id == w[2].id == w.object(w[2].id).id
    with pytest.raises(KeyError, match="no object named"):
        w["nope"]
    with pytest.raises(IndexError):
        w[len(names)]
    with pytest.raises(TypeError):
        w[1.5]


def free_sphere():
    d = phyxel.Scene.builtin("falling-sphere").to_dict()
    d["gravity"] = [0.0, 0.0, 0.0]
    return phyxel.Scene.from_dict(d).build()


def test_written_velocities_move_the_body_next_step():
    """A free body (no gravity, at rest) given a uniform velocity v moves by v·dt in one
    symplectic-Euler step (no internal forces at rest: tolerance 1e-6 m)."""
    w = free_sphere()
    b = w[0]
    x0 = b.phyxel_positions.astype(np.float64)
    v = np.tile([1.0, -2.0, 0.5], (len(x0), 1))
    b.phyxel_velocities = v
    assert np.array_equal(b.phyxel_velocities, v.astype(np.float32))
    w.step()
    assert np.allclose(b.phyxel_positions - x0, v * w.dt, atol=1e-6)


def test_a_sleeping_body_is_left_alone_until_written():
    """A soft box set down on a plane falls asleep within 2 s at 1/120 s (scene key
    `sleep`, on by default): then its positions keep their bits over ten steps, and
    writing its velocities wakes it, so the next step moves it by about v·dt."""
    d = {
        "name": "box-at-rest",
        "gravity": [0.0, -9.81, 0.0],
        "objects": [
            {"name": "ground", "shape": {"type": "plane", "size": [0.4, 0.4]},
             "spacing": 0.025, "static": True,
             "material": {"young": 1.0e6, "friction": 0.5, "contact_damping": 4.0}},
            {"name": "box", "shape": {"type": "box", "size": [0.1, 0.1, 0.1]},
             "spacing": 0.025, "position": [0.0, 0.052, 0.0],
             "material": {"young": 1.0e5, "damping": 0.01, "friction": 0.5,
                          "contact_damping": 4.0}},
        ],
    }
    w = phyxel.Scene.from_dict(d).build(backend="mls-implicit")
    box = w["box"]
    for _ in range(240):
        w.step()
        if box.asleep:
            break
    assert box.asleep
    x0 = box.phyxel_positions
    for _ in range(10):
        w.step()
    assert np.array_equal(box.phyxel_positions, x0)
    box.phyxel_velocities = np.tile([0.0, 0.5, 0.0], (len(x0), 1))
    assert not box.asleep
    w.step()
    rise = float(np.mean(box.phyxel_positions[:, 1] - x0[:, 1]))
    assert 0.2 * 0.5 * w.dt < rise < 1.5 * 0.5 * w.dt


def test_applied_forces_act_for_one_step():
    """F on every phyxel for one step changes each velocity by F dt / m (uniform field:
    no internal force; relative tolerance 1e-4)."""
    w = free_sphere()
    b = w[0]
    m = b.phyxel_masses.astype(np.float64)
    f = np.outer(m, [0.0, 10.0, 0.0])  # 10 m/s² on every phyxel
    b.apply_forces(f)
    w.step()
    dv = b.phyxel_velocities[:, 1]
    assert np.allclose(dv, 10.0 * w.dt, rtol=1e-4)
    w.step()
    assert np.allclose(b.phyxel_velocities[:, 1], dv, rtol=1e-4), "the force acted once"


def test_written_positions_take_effect():
    w = free_sphere()
    b = w[0]
    x = b.phyxel_positions + np.float32(0.25)
    b.phyxel_positions = x
    w.step()
    assert np.allclose(b.phyxel_positions, x, atol=1e-5)
    assert np.allclose(b.surfel_positions.mean(axis=0), x.mean(axis=0), atol=2e-2)


def test_bad_writes_raise_and_change_nothing():
    w = phyxel.Scene.builtin("pile").build()
    body = next(b for b in w.objects if not b.is_static)
    n = len(body.phyxel_masses)
    before = body.phyxel_positions
    with pytest.raises(ValueError, match=r"shape \(3, 3\): must be"):
        body.phyxel_velocities = np.zeros((3, 3))
    bad = np.zeros((n, 3))
    bad[5, 1] = np.nan
    with pytest.raises(ValueError, match=r"phyxel_positions\[5, 1\] = NaN"):
        body.phyxel_positions = bad
    assert np.array_equal(body.phyxel_positions, before)
    ground = next(b for b in w.objects if b.is_static)
    with pytest.raises(phyxel.Error, match="static"):
        ground.phyxel_velocities = np.zeros((len(ground.phyxel_masses), 3))
    with pytest.raises(ValueError, match="dt = 0"):
        w.dt = 0.0
    with pytest.raises(ValueError, match="gravity"):
        w.gravity = [0.0, float("inf"), 0.0]


def test_collision_conserves_momentum_and_reports_patches():
    """two-spheres through its collision: total momentum stays within 1e-5 of one
    sphere's (4.19 kg·m/s), and the patches carry equal and opposite forces on a
    contact surface of positive area."""
    w = phyxel.Scene.builtin("two-spheres").build()
    seen = False
    for _ in range(200):
        w.step()
        assert np.linalg.norm(w.momentum()) < 1e-5 * 4.19
        patches = w.patches()
        if patches:
            seen = True
            p = patches[0]
            assert {p["a"], p["b"]} == {w["left"].id, w["right"].id}
            m = len(p["areas"])
            assert p["positions"].shape == (m, 3) and p["forces"].shape == (m, 3)
            assert (p["areas"] > 0).all()
            assert np.allclose(np.linalg.norm(p["normals"], axis=1), 1, atol=1e-4)
    assert seen, "the spheres touched"
    assert w.max_penetration > 0


def test_contact_totals_sum_the_patches_and_the_summary_keeps_their_history():
    """two-spheres through its collision. Reference: the per-surfel patches (their
    force sum, to f32 rounding) and Newton's second law: the history's impulse on the
    left sphere equals its momentum change to 1% of the incoming 4.19 kg·m/s."""
    w = phyxel.Scene.builtin("two-spheres").build()
    v0 = np.average(w["left"].phyxel_velocities[:, 0], weights=w["left"].phyxel_masses)
    m = float(w["left"].phyxel_masses.sum())
    seen = False
    for _ in range(400):
        w.step()
        totals = w.contact_totals()
        patches = w.patches()
        assert len(totals) == len(patches)
        for t, p in zip(totals, patches):
            seen = True
            assert (t["a"], t["b"]) == (p["a"], p["b"])
            assert (t["a_name"], t["b_name"]) == ("left", "right")
            f = p["forces"].astype(np.float64).sum(axis=0)
            assert np.allclose(t["force"], f, rtol=1e-4, atol=1e-4 * np.abs(f).max())
            assert t["contact_surfels"] == len(p["areas"])
    assert seen, "the spheres touched"
    v1 = np.average(w["left"].phyxel_velocities[:, 0], weights=w["left"].phyxel_masses)
    (h,) = w.summary()["contacts"]
    assert h["impulse"][0] == pytest.approx(m * (v1 - v0), abs=0.01 * 4.19)


def test_the_paper_preset_is_reported_and_refused_when_misspelt():
    """`preset="paper"` reaches the summary (as `run --preset paper --json`), and the
    paper's strain is four times stiffer at small strain: a smaller stable dt."""
    scene = phyxel.Scene.builtin("two-spheres")
    default, paper = scene.build(), scene.build(preset="paper")
    assert default.summary()["preset"] == "default"
    assert paper.summary()["preset"] == "paper"
    assert paper.stable_dt < default.stable_dt
    with pytest.raises(ValueError, match="papr"):
        scene.build(preset="papr")


def test_energy_momentum_and_time():
    """Kinetic energy at the start: two spheres of the exact mass 4π/3 r³ ρ (r = 0.1 m,
    ρ = 1000 kg/m³: the MLS volumes are fitted to the sphere's) at 1 m/s."""
    w = phyxel.Scene.builtin("two-spheres").build()
    e = w.energy()
    sphere = 4 / 3 * np.pi * 0.1**3 * 1000
    assert e["kinetic"] == pytest.approx(sphere, rel=1e-5) and e["total"] == pytest.approx(sum(e[k] for k in ("kinetic", "elastic", "potential", "contact")))
    w.step(10)
    assert w.steps == 10 and w.time == pytest.approx(10 * w.dt)
    assert w.non_finite is None


def test_a_blow_up_raises_non_finite_error_and_stays_readable():
    w = phyxel.Scene.builtin("falling-sphere").build(dt=1e-3, allow_unstable=True)
    w.dt = 50 * w.stable_dt
    with pytest.raises(phyxel.NonFiniteError, match="step"):
        w.step(2000)
    assert w.non_finite is not None
    assert w.summary()["finite"] is False


def test_frames_and_pictures(tmp_path):
    w = phyxel.Scene.builtin("two-spheres").build()
    w.step(120)
    ply = tmp_path / "f.ply"
    w.write_frame(ply)
    assert ply.read_bytes().startswith(b"ply\nformat binary_little_endian")
    vtp = tmp_path / "f.vtp"
    w.write_frame(vtp, format="vtk")
    assert b"<VTKFile" in vtp.read_bytes()[:200]
    contacts = tmp_path / "c.ply"
    w.write_frame(contacts, contacts=True)
    n = sum(len(p["areas"]) for p in w.patches())
    assert n > 0 and f"element vertex {n}\n".encode() in contacts.read_bytes()[:200]
    assert b"property float penetration" in contacts.read_bytes()[:800]
    with pytest.raises(ValueError, match="one per call"):
        w.write_frame(contacts, phyxels=True, contacts=True)
    fixed = tmp_path / "fixed.ply"
    w.write_frame(fixed, fixed_points=True)
    total = w.summary()["surfels"]
    assert f"element vertex {total}\n".encode() in fixed.read_bytes()[:200]
    with pytest.raises(ValueError):
        w.write_frame(tmp_path / "x", format="obj")
    with pytest.raises(phyxel.Error, match="cannot write"):
        w.write_frame(tmp_path / "missing" / "f.ply")
    img = w.render(size=(200, 150))
    assert img.shape == (150, 200, 3) and img.dtype == np.uint8
    assert img.std() > 5, "the picture shows something"
    with pytest.raises(ValueError):
        w.render(size=(0, 10))


def test_step_releases_the_gil():
    """A Python thread runs while the world steps (it would not if the GIL were held)."""
    w = phyxel.Scene.builtin("two-spheres").build()
    ticks = []
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=tick)
    t.start()
    w.step(300)
    stop.set()
    t.join()
    assert len(ticks) > 10


def test_ctrl_c_stops_stepping_between_steps():
    # An interrupt from the operating system (SIGALRM handled as SIGINT is, by raising
    # KeyboardInterrupt), answered between steps. Not a timer thread calling
    # `_thread.interrupt_main`: that thread must first win the GIL from the stepping
    # loop, and once, in a CI run, it did not for 28 minutes.
    previous = signal.signal(signal.SIGALRM, signal.default_int_handler)
    try:
        w = phyxel.Scene.builtin("two-spheres").build()
        signal.setitimer(signal.ITIMER_REAL, 0.2)
        with pytest.raises(KeyboardInterrupt):
            w.step(10**9)
        assert 0 < w.steps < 10**9
        w.step()  # still usable
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def test_compare_and_validate_return_rows():
    rows = phyxel.compare("two-spheres", steps=5)
    assert [r["backend"] for r in rows] == list(phyxel.BACKENDS)
    v = phyxel.validate(quick=True, case="mls-consistency", backend="mls")
    assert v and all(r["case"] == "mls-consistency" for r in v)
    with pytest.raises(ValueError, match="unknown backend"):
        phyxel.validate(backend="nope")


def test_to_pandas():
    pd = pytest.importorskip("pandas")
    df = phyxel.to_pandas(phyxel.compare("two-spheres", steps=3))
    assert len(df) == len(phyxel.BACKENDS) and "energy_final.kinetic" in df.columns
    assert isinstance(df, pd.DataFrame)


def test_docstrings_carry_no_rust_link_syntax():
    """`help()` on the module's classes, functions and methods reads as Python: no
    rustdoc links (`[`Name`]`, `](target)`) or Rust paths (`crate::`, `a::b`)."""
    import inspect
    import re

    rust = re.compile(r"\[`[^\]]*`\]|\]\(|\bcrate::|`[A-Za-z_]+::[A-Za-z_]")
    found = []
    for name in dir(phyxel._phyxel):
        obj = getattr(phyxel._phyxel, name)
        members = [(name, obj)]
        if inspect.isclass(obj):
            members += [(f"{name}.{m}", getattr(obj, m)) for m in dir(obj) if not m.startswith("_")]
        for label, member in members:
            doc = inspect.getdoc(member) or ""
            found += [f"{label}: {line}" for line in doc.splitlines() if rust.search(line)]
    assert not found, found


def test_vectors_come_back_as_numpy_arrays():
    """Vectors the API returns are float64 NumPy arrays of 3: the momentum, and the
    force, friction force, centre, torque and centroid of each contact pair."""
    w = phyxel.Scene.builtin("two-spheres").build()
    p = w.momentum()
    assert isinstance(p, np.ndarray) and p.dtype == np.float64 and p.shape == (3,)
    while not w.contact_totals():
        w.step()
    (t,) = w.contact_totals()
    for key in ("force", "friction_force", "centre", "torque", "centroid"):
        assert isinstance(t[key], np.ndarray) and t[key].shape == (3,), key
