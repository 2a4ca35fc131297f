"""`phyxel.Scene`: reading scenes every way, and the errors bad ones raise.

References: the scene files themselves (a scene read back from its own TOML or dict is
the same scene) and the engine's messages (file, field and value)."""

import pathlib

import pytest

import phyxel


def test_scenes_lists_every_builtin_with_a_description():
    names = [n for n, _ in phyxel.scenes()]
    assert "two-spheres" in names and "pile" in names and len(names) >= 13
    assert all(d for _, d in phyxel.scenes())


def test_builtin_scene_reads_back_from_toml_and_dict():
    s = phyxel.Scene.builtin("pile")
    assert s.name == "pile" and s.steps > 0
    again = phyxel.Scene.from_toml(s.to_toml())
    assert again.to_toml() == s.to_toml()
    from_dict = phyxel.Scene.from_dict(s.to_dict())
    assert from_dict.to_toml() == s.to_toml()
    assert s.object_names == [o["name"] for o in s.to_dict()["objects"]]


def test_load_reads_a_file_and_names_the_scene_after_it(tmp_path):
    path = tmp_path / "mine.toml"
    text = phyxel.Scene.builtin("falling-sphere").to_toml().replace('name = "falling-sphere"\n', "")
    path.write_text(text)
    s = phyxel.Scene.load(path)
    assert s.name == "mine"
    assert s.build().steps == 0


def test_unknown_builtin_raises_scene_error_naming_it():
    with pytest.raises(phyxel.SceneError, match="nope: not a built-in scene") as e:
        phyxel.Scene.builtin("nope")
    assert e.value.origin == "nope"
    assert isinstance(e.value, phyxel.Error)


def test_bad_value_names_origin_and_field():
    d = phyxel.Scene.builtin("two-spheres").to_dict()
    d["objects"][1]["spacing"] = -1
    with pytest.raises(phyxel.SceneError, match="spacing = -1") as e:
        phyxel.Scene.from_dict(d, origin="mine")
    assert e.value.origin == "mine"
    assert e.value.field == "objects[1].spacing"
    assert e.value.value == "-1"


def test_unknown_key_and_bad_toml_are_refused():
    d = phyxel.Scene.builtin("two-spheres").to_dict()
    d["gravitee"] = [0, 0, 0]
    with pytest.raises(phyxel.SceneError, match="gravitee"):
        phyxel.Scene.from_dict(d)
    with pytest.raises(phyxel.SceneError):
        phyxel.Scene.from_toml("objects = [")
    with pytest.raises(phyxel.SceneError, match="cannot read"):
        phyxel.Scene.load(pathlib.Path("/nonexistent/scene.toml"))


def test_a_scene_past_the_memory_budget_is_refused():
    scene = phyxel.Scene.builtin("two-spheres")
    with pytest.raises(phyxel.SceneError, match="needs about .* budget of 1.0 KiB"):
        scene.build(max_memory=1024)
    with pytest.raises(phyxel.SceneError, match="--max-memory"):
        phyxel.run("two-spheres", steps=1, max_memory=1024)
    assert scene.build(max_memory=1 << 30).steps == 0


def test_dt_above_the_bound_raises_unstable_error_with_the_bound():
    s = phyxel.Scene.builtin("two-spheres")
    bound = s.build().stable_dt
    with pytest.raises(phyxel.UnstableError) as e:
        s.build(dt=2 * bound)
    assert e.value.field == "dt"
    assert e.value.bound == pytest.approx(bound, rel=1e-6)
    # Accepted when asked for.
    assert s.build(dt=2 * bound, allow_unstable=True).dt == pytest.approx(2 * bound)


def test_build_options_take_effect():
    s = phyxel.Scene.builtin("two-spheres")
    w = s.build(backend="sph", surfels=2000, phyxels=200, dt=1e-4)
    assert [b.backend for b in w.objects] == ["sph", "sph"]
    assert w.dt == pytest.approx(1e-4)
    for b in w.objects:
        assert abs(len(b.surfel_radii) - 2000) < 400
        assert abs(len(b.phyxel_masses) - 200) < 80
    with pytest.raises(phyxel.SceneError, match="backend"):
        s.build(backend="nope")


def test_refine_zone_from_a_dict_builds_a_graded_body():
    """A `refine` zone given in a dict (the scene key of docs/SCENES.md): the body has
    more phyxels than the uniform one, the same mass (the sphere's: ρ 4/3 π r³, 1e-4),
    and surfels of two disk radii; the key reads back from the scene's TOML."""
    d = phyxel.Scene.builtin("falling-sphere").to_dict()
    uniform = phyxel.Scene.from_dict(d).build()
    d["objects"][0]["refine"] = [{"centre": [0.0, -0.1, 0.0], "radius": 0.04, "spacing": 0.01}]
    scene = phyxel.Scene.from_dict(d)
    assert "refine" in scene.to_toml()
    graded = scene.build()
    b, u = graded.objects[0], uniform.objects[0]
    assert len(b.phyxel_positions) > len(u.phyxel_positions)
    assert abs(b.mass / u.mass - 1.0) < 1e-4
    assert len(set(b.surfel_radii.round(7))) == 2
