#!/usr/bin/env python3
"""Peer benchmark: SPlisHSPlasH (pysplishsplash 2.19.0) elastic solids on phyxel's
cantilever and ball-impact cases. Prints one JSON object per run on stdout.

Each run is a child process of this script: SPlisHSPlasH keeps global singletons
(Simulation, TimeManager) that do not re-initialise cleanly, and libgomp reads
OMP_NUM_THREADS only when it loads. Run via splishsplash.sh (venv + GL preload).
"""
import argparse, json, math, os, shutil, subprocess, sys, tempfile, time

# elasticityMethod enum value and the scene-file block name of each solid method
METHODS = {"becker2009": (1, "Becker et al. 2009"), "peer2018": (2, "Peer et al. 2018"),
           "kugelstadt2021": (3, "Kugelstadt et al. 2021")}

# ---- case definitions (must match phyxel's benches) ----
RHO, NU = 1000.0, 0.3
BAR_L, BAR_T, CLAMP_X = 1.0, 0.1, -0.45        # bar 1.0 x 0.1 x 0.1, fixed where x <= -0.45
BAR_E, G = 1e8, 9.81
BALL_R, BALL_E, BALL_V, GAP = 0.1, 1e6, 0.5, 0.03  # src/lib.rs, mod ball


def cantilever_reference():
    L, b = BAR_L / 2 - CLAMP_X, BAR_T           # free length 0.95 m, square section
    I, q = b * b ** 3 / 12, RHO * G * b * b
    delta = q * L ** 4 / (8 * BAR_E * I)
    omega = 1.875104 ** 2 * math.sqrt(BAR_E * I / (RHO * b * b * L ** 4))
    return delta, 2 * math.pi / omega           # 0.011986 m, 0.1767 s


def hertz_tc():
    m = RHO * 4 / 3 * math.pi * BALL_R ** 3
    estar = BALL_E / (1 - NU ** 2)              # ball on a rigid plane
    return 2.868 * (m * m / (BALL_R * estar ** 2 * BALL_V)) ** 0.2   # ~0.0355 s


def lattice(n, d):
    """n cell-centred lattice coordinates with spacing d, symmetric about 0."""
    return [(k - (n - 1) / 2) * d for k in range(n)]


def write_pda(path, pts):
    # Partio's ASCII format: lets us place every particle exactly (FluidBlocks can't do a sphere)
    with open(path, "w") as f:
        f.write("ATTRIBUTES\nposition\nTYPES\nV\nNUMBER_OF_PARTICLES: %d\nBEGIN DATA\n" % len(pts))
        f.writelines("%.9g %.9g %.9g\n" % p for p in pts)


def write_box_obj(path):
    # unit cube, outward-facing CCW triangles (volume-map boundary needs a closed mesh)
    v = [(x, y, z) for z in (-.5, .5) for y in (-.5, .5) for x in (-.5, .5)]
    v = [v[0], v[1], v[3], v[2], v[4], v[5], v[7], v[6]]
    faces = [(1, 4, 3), (1, 3, 2), (5, 6, 7), (5, 7, 8), (1, 2, 6), (1, 6, 5),
             (4, 8, 7), (4, 7, 3), (1, 5, 8), (1, 8, 4), (2, 3, 7), (2, 7, 6)]
    with open(path, "w") as f:
        f.writelines("v %g %g %g\n" % p for p in v)
        f.writelines("f %d %d %d\n" % t for t in faces)


def build_scene(spec, tmp):
    d = BAR_T / spec["res"] if spec["case"] == "cantilever" else BALL_R / spec["res"]
    enum, block = METHODS[spec["method"]]
    cfl = spec["dt"] == "cfl"
    conf = {"particleRadius": d / 2, "timeStepSize": 0.001 if cfl else float(spec["dt"]),
            "cflMethod": 1 if cfl else 0, "enableZSort": False, "boundaryHandlingMethod": 2,
            "stopAt": -1, "enablePartioExport": False, "enableVTKExport": False}
    elastic = {"youngsModulus": BAR_E, "poissonsRatio": NU}
    model = {"particleFile": os.path.join(tmp, "body.pda")}
    scene = {"Configuration": conf, "FluidModels": [model]}
    if spec["case"] == "cantilever":
        n = spec["res"]
        pts = [(x, y, z) for x in lattice(round(BAR_L / d), d)
               for y in lattice(n, d) for z in lattice(n, d)]
        # WCSPH with zero stiffness = no pressure forces, as in SPlisHSPlasH's own Beam.json:
        # the elastic solver alone carries the load (no boundaries in this scene)
        conf.update(gravitation=[0, -G, 0], simulationMethod=0, WCSPH={"stiffness": 0.0, "exponent": 1.0})
        # bounds included, as phyxel's `fixed` box and Rapier's pins: at an odd count through
        # the thickness a particle layer lies on the clamp's face x = -0.45
        elastic.update(fixedBoxMin=[-1.0, -1.0, -1.0], fixedBoxMax=[CLAMP_X + 1e-4, 1.0, 1.0])
    else:
        n = spec["res"]
        c = lattice(2 * n, d)
        pts = [(x, y + BALL_R + spec.get("gap", GAP), z) for x in c for y in c for z in c
               if x * x + y * y + z * z < BALL_R ** 2]   # cells whose centre is inside the sphere
        # contact with the static box only exists through the pressure solver, so use DFSPH
        # (as SPlisHSPlasH's DeformableModel/DeformableBunnies scenes do); it also resists compression
        conf.update(gravitation=[0, 0, 0], simulationMethod=4)
        elastic["youngsModulus"] = BALL_E
        model["initialVelocity"] = [0, -BALL_V, 0]
        write_box_obj(os.path.join(tmp, "box.obj"))
        scene["RigidBodies"] = [{"geometryFile": os.path.join(tmp, "box.obj"), "translation": [0, -0.1, 0],
                                 "scale": [1, 0.2, 1], "isDynamic": False, "isWall": False,
                                 "mapInvert": False, "mapThickness": 0.0, "mapResolution": [40, 20, 40]}]
    scene["Materials"] = [{"id": "Fluid", "density0": RHO, "elasticityMethod": enum,
                           "viscosityMethod": 0, block: elastic}]
    write_pda(model["particleFile"], pts)
    path = os.path.join(tmp, "scene.json")
    with open(path, "w") as f:
        json.dump(scene, f, indent=1)
    return path, pts, d, elastic["youngsModulus"]


def child(spec):
    """One simulation; prints 'RESULT {json}'."""
    import numpy as np
    import pysplishsplash as sph
    tmp = tempfile.mkdtemp(prefix="sphpeer-")
    scene, pts, d, E = build_scene(spec, tmp)
    base = sph.Exec.SimulatorBase()
    base.init(sceneFile=scene, useCache=False, outputDir=tmp, initialPause=False, useGui=False)
    base.initSimulation()
    sim, tm = sph.Simulation.getCurrent(), sph.TimeManager.getCurrent()
    fm = sim.getFluidModel(0)
    el = fm.getElasticityBase()
    # unknown scene keys are silently ignored: check the solver really got our material
    assert el.getMethodName() == METHODS[spec["method"]][1], el.getMethodName()
    assert abs(el.getValueFloat(el.YOUNGS_MODULUS) / E - 1) < 1e-6
    assert fm.numActiveParticles() == len(pts)
    x0 = np.array(pts)

    def field(name):  # zero-copy view; rows = file order (z-sort off), capacity includes emitter reserve
        return np.asarray(fm.getFieldBuffer(name))[:len(pts)]

    # The bindings do not expose SimulatorBase::deferredInit (it initialises the elasticity
    # solver), so we must drive the loop with runSimulation() and observe from the per-step
    # callback. Stepping wall time = time between callbacks; the first step is excluded
    # (no timestamp before it), as is everything the callback itself does.
    clock = dict(wall=0.0, steps=0, t_first=None, last=None, iters=0)
    it_param = getattr(el, "ITERATIONS", getattr(el, "ITERATIONS_V", None))  # Peer: CG, Kugelstadt: volume solver

    def run(observe):
        def cb():
            now = time.perf_counter()
            if clock["last"] is None:
                clock["t_first"] = tm.getTime()
            else:
                clock["wall"] += now - clock["last"]
                clock["steps"] += 1
            clock["iters"] += el.getValueUInt(it_param) if it_param is not None else 0
            if observe(tm.getTime()):
                base.setValueFloat(base.STOP_AT, 1e-12)   # stopAt < time ends runSimulation
            clock["last"] = time.perf_counter()
        base.setTimeStepCB(cb)
        base.setValueFloat(base.STOP_AT, 1e9)
        base.runSimulation()

    if spec["case"] == "cantilever":
        delta_ref, period = cantilever_reference()
        tip = x0[:, 0] > BAR_L / 2 - d / 2 - 1e-9            # last particle layer at the free end
        t_end = 2 * period
        ts, defl = [0.0], [0.0]

        def observe(t):
            ts.append(t)
            defl.append(-(field("position")[tip, 1].mean() - x0[tip, 1].mean()))
            if not np.isfinite(defl[-1]) or abs(defl[-1]) > 1.0:
                raise SystemExit("diverged at t=%.4g" % t)
            return t >= t_end
        run(observe)
        ts, defl = np.array(ts), np.array(defl)
        if os.environ.get("SPH_TRACE"):  # debugging aid: time series of the tip deflection
            np.savetxt(os.environ["SPH_TRACE"], np.c_[ts, defl])
        dts = np.diff(ts)
        mid = 0.5 * (defl[1:] + defl[:-1])                    # trapezoid time average
        # first maximum of the tip deflection: first local max after it has started to move
        k = next((i for i in range(1, len(defl) - 1)
                  if defl[i] >= defl[i - 1] and defl[i] > defl[i + 1] and defl[i] > 0.2 * delta_ref), None)
        measure = "mean over [0, first max]"
        measured = (mid[:k] * dts[:k]).sum() / ts[k] if k else float("nan")
        # undamped response peaks at ~2x its mean; far below that = heavily damped
        if k is None or defl[k] < 1.5 * measured:
            sel = ts[1:] > ts[-1] * 2 / 3
            measured = (mid[sel] * dts[sel]).sum() / dts[sel].sum()
            measure = "damped: mean over last third of 2 periods"
        res = dict(measured=measured, reference=delta_ref, tip_max=float(defl.max()),
                   t_first_max=float(ts[k]) if k else None, measure=measure)
    else:
        tc_ref = hertz_tc()
        v_in = -BALL_V
        thr = 1e-4 * BALL_V        # per-step change of COM velocity that counts as "in contact"
        st = dict(vy=v_in, t=0.0, start=None, stop=None, min_y=x0[:, 1].mean())
        trace = []

        def observe(t):
            vy = field("velocity")[:, 1].mean()
            y = field("position")[:, 1].mean()
            st["min_y"] = min(st["min_y"], y)
            trace.append((t, y, vy))
            # Contact rule: a step is "in contact" when the COM y-velocity changes by more than
            # 1e-4 * |v_in| over that step (no gravity, so free flight keeps it constant).
            # t_c runs from the start of the first such step to the end of the last one.
            if abs(vy - st["vy"]) > thr:
                st["start"] = st["t"] if st["start"] is None else st["start"]
                st["stop"] = t
            st["vy"], st["t"] = vy, t
            if not math.isfinite(vy):
                raise SystemExit("diverged at t=%.4g" % t)
            return t >= 0.2 or (st["stop"] is not None and vy > 0 and t > st["stop"] + 0.1)
        run(observe)
        if os.environ.get("SPH_TRACE"):  # debugging aid: COM height and velocity
            np.savetxt(os.environ["SPH_TRACE"], trace)
        # The rule of src/lib.rs (ContactTimer), so every engine is timed alike: the contact
        # runs from the first to the last step whose COM acceleration exceeds 0.1% of the peak.
        tr = np.array([(0.0, 0.0, v_in)] + trace)
        step = np.diff(tr[:, 0])
        acc = np.abs(np.diff(tr[:, 2])) / np.where(step > 0, step, np.inf)
        on = np.nonzero(acc > 1e-3 * acc.max())[0]
        t_c = float(step[on[0]:on[-1] + 1].sum()) if acc.max() > 0 and on[-1] + 1 < len(acc) else float("nan")
        res = dict(measured=t_c, reference=tc_ref, t_c=t_c, e_rebound=st["vy"] / -v_in,
                   min_com_y=float(st["min_y"]), contact_start=st["start"], gap=spec["gap"])
    wall, steps = clock["wall"], clock["steps"] + 1
    res["solver_iters"] = clock["iters"] / steps
    sim_time = tm.getTime()
    out = dict(engine="splishsplash", method=spec["method"], case=spec["case"], resolution=spec["res"],
               particles=len(pts), threads=int(os.environ.get("OMP_NUM_THREADS", "0")),
               dt_mode=spec["dt"], dt=sim_time / steps, steps=steps, wall=wall, sim_time=sim_time,
               wall_per_sim=wall / (sim_time - clock["t_first"]), **res)
    out["error"] = out["measured"] / out["reference"] - 1
    if "damped" in out.get("measure", ""):
        out["method"] += " (damped: last-third mean)"
    shutil.rmtree(tmp, ignore_errors=True)   # kept on failure, for its log/
    print("RESULT " + json.dumps(out, default=float), flush=True)  # Real is float32 in the wheel


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="coarse resolution only")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--cases", default="cantilever,ball-impact")
    ap.add_argument("--methods", default="peer2018,kugelstadt2021", help=",".join(METHODS))
    ap.add_argument("--dts", default="1e-4,1e-3", help="'cfl' = SPlisHSPlasH's adaptive step "
                    "(velocity-based: 2-5 ms on these solids, +275%% / -84%% on the cantilever)")
    ap.add_argument("--gap", type=float, default=GAP, help="ball-impact: initial gap (m); SPlisHSPlasH's "
                    "boundary already acts within the kernel support 2*spacing")
    ap.add_argument("--res", help="only these resolutions (comma-separated), e.g. 5,7")
    ap.add_argument("--timeout", type=float, default=1800, help="per run, seconds")
    ap.add_argument("--verbose", action="store_true", help="pass SPlisHSPlasH's log to stderr")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        return child(json.loads(a.child))
    resolutions = {"cantilever": [3, 4, 5, 6, 7, 8, 9], "ball-impact": [8, 12, 16]}
    for case in a.cases.split(","):
        todo = resolutions[case][:1] if a.quick else resolutions[case]
        if a.res:
            todo = [r for r in todo if str(r) in a.res.split(",")]
        for res in todo:
            for method in a.methods.split(","):
                for dt in a.dts.split(","):
                    for th in a.threads.split(","):
                        spec = dict(case=case, res=res, method=method, dt=dt, gap=a.gap)
                        env = dict(os.environ, OMP_NUM_THREADS=th)
                        t0 = time.time()
                        try:
                            p = subprocess.run([sys.executable, __file__, "--child", json.dumps(spec)], env=env,
                                               capture_output=True, text=True, timeout=a.timeout)
                            out, err, rc = p.stdout, p.stderr, p.returncode
                        except subprocess.TimeoutExpired as e:
                            out, err, rc = e.stdout or "", "timeout", "timeout"
                            out = out.decode() if isinstance(out, bytes) else out
                        lines = [l[7:] for l in out.splitlines() if l.startswith("RESULT ")]
                        if a.verbose:
                            sys.stderr.write(out + err)
                        if lines:  # elapsed = whole child incl. setup (volume maps etc.)
                            print(lines[-1][:-1] + ', "elapsed": %.1f}' % (time.time() - t0), flush=True)
                        else:  # report the failure as a line too, so the sweep keeps going
                            tail = (err.strip().splitlines() or out.strip().splitlines() or [""])[-1]
                            print(json.dumps(dict(engine="splishsplash", method=method, case=case, resolution=res,
                                                  threads=int(th), dt_mode=dt, failed=f"rc={rc}: {tail}"[:300],
                                                  elapsed=time.time() - t0)), flush=True)


if __name__ == "__main__":
    main()
