"""`World.run(steps, record=..., every=...)`: quantities sampled in Rust, as NumPy arrays,
checked against independent reads of the same world and against conservation."""

import numpy as np
import pytest

import phyxel


def test_run_records_what_the_world_shows():
    """`two-spheres` for 300 steps (through the collision), everything recorded: the
    samples are steps 0..300 at `step × dt`; the last sample's centres of mass equal the
    mass-weighted mean of `phyxel_positions` (read independently, 1e-9 m); total
    momentum `Σ m v` stays at its start (the bodies only push each other: within 1e-6 of
    one sphere's momentum); the pair's normal force is zero before contact, positive
    during it, and equals `contact_totals()` at the last step; the recorded total energy
    equals `world.energy()` at the end."""
    world = phyxel.Scene.builtin("two-spheres").build()
    r = world.run(300, record=["com", "velocity", "energy", "contacts", "tool_force"])
    assert r["bodies"] == ["left", "right"]
    assert np.array_equal(r["step"], np.arange(301))
    assert np.allclose(r["time"], r["step"] * world.dt, rtol=1e-6)
    for j, name in enumerate(r["bodies"]):
        body = world[name]
        m = body.phyxel_masses.astype(np.float64)
        com = (body.phyxel_positions.astype(np.float64) * m[:, None]).sum(axis=0) / m.sum()
        assert np.allclose(r["com"][-1, j], com, atol=1e-9)
    masses = np.array([world[n].mass for n in r["bodies"]])
    momentum = (r["velocity"] * masses[None, :, None]).sum(axis=1)
    scale = masses[0] * np.linalg.norm(r["velocity"][0, 0])
    assert np.abs(momentum - momentum[0]).max() < 1e-6 * scale
    assert r["pairs"] == [("left", "right")]
    force = r["normal_force"][:, 0]
    assert force[0] == 0.0 and force.max() > 0.0
    totals = world.contact_totals()
    if totals:
        assert force[-1] == pytest.approx(totals[0]["normal_force"], rel=1e-12)
    assert r["energy"]["total"][-1] == pytest.approx(world.energy()["total"], rel=1e-12)
    assert r["tools"] == [] and r["tool_force"].shape == (301, 0, 3)


def test_every_samples_the_start_every_k_steps_and_the_end():
    world = phyxel.Scene.builtin("falling-sphere").build()
    r = world.run(10, record=["com"], every=4)
    assert list(r["step"]) == [0, 4, 8, 10]
    assert r["com"].shape == (4, 1, 3)
    assert r["com"][-1, 0, 1] < r["com"][0, 0, 1], "it falls"
    with pytest.raises(ValueError, match="unknown quantity 'speed'.*com, velocity"):
        world.run(1, record=["speed"])
    with pytest.raises(ValueError, match="every = 0"):
        world.run(1, every=0)
    one = world.run(2, record="velocity")
    assert "velocity" in one and "com" not in one
    with pytest.raises(TypeError, match="record = 5: a quantity's name or a list"):
        world.run(1, record=5)


def test_a_record_becomes_one_row_per_sample():
    pd = pytest.importorskip("pandas")
    world = phyxel.Scene.builtin("two-spheres").build()
    r = world.run(200, every=10)
    df = phyxel.to_pandas(r)
    assert isinstance(df, pd.DataFrame) and len(df) == 21
    assert list(df["step"]) == list(range(0, 201, 10))
    for column in ["time", "left.com.x", "right.velocity.z", "left/right.normal_force"]:
        assert column in df.columns
    assert np.array_equal(df["left.com.x"].to_numpy(), r["com"][:, 0, 0])


def test_the_tool_force_is_the_kinematic_reaction():
    """A kinematic body's recorded force is its `Kinematic::reaction`: the contact force
    the pipeline handed it for its step, i.e. the opposite of the force on the ball at
    the contact phase of the step before. A tool pressed into an anchored soft ball:
    the recorded force at each sample equals, within 1e-5 of its size (an f32 sum over the
    tool's phyxels against the f64 totals), the negated
    `contact_totals()` force on the ball one step earlier, read step by step from a
    second, identical world (the engine is deterministic)."""
    scene = phyxel.Scene.from_toml(
        "gravity = [0.0, 0.0, 0.0]\n"
        "[[objects]]\nname = \"ball\"\nshape = { type = \"sphere\", radius = 0.1 }\n"
        "spacing = 0.02\nmaterial = { young = 2.0e4 }\n"
        "fixed = [{ min = [-0.1, -0.1, -0.1], max = [0.1, -0.06, 0.1] }]\n"
        "[[objects]]\nname = \"tool\"\nbackend = \"kinematic\"\n"
        "shape = { type = \"sphere\", radius = 0.03 }\nspacing = 0.01\n"
        "position = [0.0, 0.135, 0.0]\nvelocity = [0.0, -0.1, 0.0]\n"
    )
    world = scene.build()
    steps = int(0.1 / world.dt)
    r = world.run(steps, record=["tool_force"])
    assert r["tools"] == ["tool"]
    assert r["tool_force"][-1, 0, 1] > 0.0, "the ball pushes the tool back up"
    twin = scene.build()
    on_ball = [np.zeros(3)]
    for _ in range(steps):
        twin.step()
        totals = twin.contact_totals()
        force = np.zeros(3)
        for t in totals:
            force += np.array(t["force"]) * (1 if t["a_name"] == "ball" else -1)
        on_ball.append(force)
    for k in range(2, steps + 1):
        want = -on_ball[k - 1]
        assert np.linalg.norm(r["tool_force"][k, 0] - want) <= 1e-5 * np.linalg.norm(want), k
