"""`Scene.from_dict` fuzzed: the built-in scenes' dicts mutated (a leaf replaced by an
extreme or a value of another type, a key deleted or added, a list emptied) with a fixed
seed. Each must give a Scene or raise `phyxel.SceneError` (or `TypeError`/`ValueError`)
with a message; every Scene that results is built under a 64 MiB budget and stepped twice,
which must give a World or a `phyxel.Error`, never another exception.
`PHYXEL_FUZZ_CASES` sets how many mutations (default 300)."""

import copy
import math
import os
import random

import numpy as np

import phyxel

CASES = int(os.environ.get("PHYXEL_FUZZ_CASES", "300"))

EXTREMES = [
    0, -1, 1, 2**70, -(2**63), 0.0, -0.0, 1e-39, 1e39, 3.5e38, math.nan, math.inf, -math.inf,
    True, False, "", "x", "\x1b[31m", None, [], {}, [1.0, 2.0], {"a": 1},
    np.float64(0.5), np.int32(3), np.array([0.1, 0.2, 0.3]), np.array([[1.0]]), (1.0, 2.0, 3.0),
    object(),
]

NEW_KEYS = ["bogus", "steps", "dt", "gravity", "spacing", "velocity", "fixed", "static"]


def leaves(d, path=()):
    """Every (container, key) of `d`, nested dicts and lists included."""
    items = d.items() if isinstance(d, dict) else enumerate(d)
    for k, v in items:
        yield d, k
        if isinstance(v, (dict, list)):
            yield from leaves(v, path + (k,))


def mutate(d, rng):
    d = copy.deepcopy(d)
    for _ in range(rng.randint(1, 3)):
        spots = list(leaves(d))
        if not spots:
            break
        container, key = rng.choice(spots)
        what = rng.random()
        if what < 0.7:
            container[key] = rng.choice(EXTREMES)
        elif what < 0.85 and isinstance(container, dict):
            del container[key]
        elif isinstance(container, dict):
            container[rng.choice(NEW_KEYS)] = rng.choice(EXTREMES)
        elif isinstance(container, list):
            container.clear()
    return d


def test_mutated_scene_dicts_give_a_scene_or_a_named_error():
    rng = random.Random(0x70687978)
    names = phyxel.scenes()
    names = [n if isinstance(n, str) else n[0] for n in names]
    bases = {n: phyxel.Scene.builtin(n).to_dict() for n in names if n not in ("scale",)}
    tally = {"refused": 0, "built": 0, "stepped": 0, "build_refused": 0}
    for k in range(CASES):
        name = rng.choice(sorted(bases))
        d = mutate(bases[name], rng)
        try:
            scene = phyxel.Scene.from_dict(d, origin=f"case{k}")
        except (phyxel.SceneError, TypeError, ValueError) as e:
            assert str(e).strip(), f"case {k}: empty message for {d!r:.300}"
            assert "\x1b" not in str(e), f"case {k}: raw escape in {e!r}"
            tally["refused"] += 1
            continue
        tally["built"] += 1
        try:
            world = scene.build(max_memory=64 << 20)
        except phyxel.Error as e:
            assert str(e).strip()
            tally["build_refused"] += 1
            continue
        try:
            world.step(2)
        except phyxel.Error as e:
            assert str(e).strip()
        tally["stepped"] += 1
    print(tally)
    assert tally["refused"] > CASES // 4 and tally["built"] > CASES // 20, tally
