//! Random-scene soak: a few hundred scenes of random shapes, materials, velocities,
//! placements (some overlapping) and backends, within the validated ranges, each built
//! and stepped 100–200 times at its default dt. Every scene either is refused with a
//! message, or runs to the end finite, or stops with a named non-finite message; none
//! panics. Where no external force acts (no gravity, no static body), the total
//! momentum stays the initial one within [`MOMENTUM_TOLERANCE`] of the momentum scale.
//!
//! Some scenes have a kinematic tool (a rigid sphere driven along +x at a random speed
//! into the row of bodies). At every step no body's centre of mass may lie inside
//! another body ([`centre_inside`]): contact that lets bodies pass through each other
//! fails the soak, at any dt the scene defaults to.
//!
//! Every scene is printed (seed and TOML) before it runs, so a failure shows what to
//! rerun: `PHYXEL_SOAK_SEED=<seed> cargo test --release --test hostile soak:: -- --nocapture`
//! runs that one scene; `PHYXEL_SOAK_SCENES=N` sets how many (default [`SCENES`]).

use phyxel::World;
use phyxel::scene::{BuildOptions, Scene};

/// Scenes per run (about 50 s on two cores).
const SCENES: u64 = 240;
/// The first seed: scene k has seed `FIRST_SEED + k`.
const FIRST_SEED: u64 = 0x50a4_0000;
/// Momentum drift allowed without external forces, as a fraction of `Σ m |v|` at the
/// start. Reference: Newton's third law. Contact forces act in equal and opposite
/// pairs and the backends' internal forces are pairwise, so the sum changes only by f32
/// rounding of the per-phyxel updates (about 1e-7 of the scale per step, a few hundred
/// steps: 1e-4 leaves a margin of some thirty), and, for `mls-implicit`, by the
/// residual of its Newton solve, which its tolerance bounds.
const MOMENTUM_TOLERANCE: f64 = 1e-4;

/// SplitMix64: a small, seedable generator, so that a seed reproduces a scene.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Log-uniform in [lo, hi).
    fn log(&mut self, lo: f64, hi: f64) -> f64 {
        self.range(lo.ln(), hi.ln()).exp()
    }
    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[(self.next() % items.len() as u64) as usize]
    }
    fn chance(&mut self, p: f64) -> bool {
        self.range(0.0, 1.0) < p
    }
}

/// One random scene as TOML, and whether an external force acts (gravity, a static
/// body or a kinematic tool).
fn random_scene(seed: u64) -> (String, bool) {
    let mut r = Rng(seed);
    let gravity = r.chance(0.5);
    let ground = gravity && r.chance(0.7);
    let n = 2 + r.next() % 3;
    let steps = 100 + r.next() % 101;
    let mut toml = format!("name = \"soak-{seed:x}\"\nsteps = {steps}\n");
    toml += if gravity {
        "gravity = [0.0, -9.81, 0.0]\n"
    } else {
        "gravity = [0.0, 0.0, 0.0]\n"
    };
    if ground {
        toml += "[[objects]]\nname = \"ground\"\nshape = { type = \"plane\", size = [1.5, 1.5] }\n\
                 spacing = 0.05\nstatic = true\nposition = [0.0, -0.15, 0.0]\n";
    }
    // Objects along x, each gap random: mostly apart, sometimes touching or overlapping
    // (a scene the build must refuse by name, or a contact from the first step).
    let mut x = -0.3;
    for k in 0..n {
        let (shape, size) = match r.next() % 4 {
            0 => {
                let radius = r.range(0.03, 0.08);
                (
                    format!("{{ type = \"sphere\", radius = {radius:.4} }}"),
                    radius,
                )
            }
            1 => {
                let s = [
                    r.range(0.05, 0.15),
                    r.range(0.05, 0.15),
                    r.range(0.05, 0.15),
                ];
                let half = s.iter().fold(0.0f64, |m, &v| m.max(v)) / 2.0;
                let shape = format!(
                    "{{ type = \"box\", size = [{:.4}, {:.4}, {:.4}] }}",
                    s[0], s[1], s[2]
                );
                (shape, half)
            }
            2 => {
                let (radius, length) = (r.range(0.025, 0.05), r.range(0.02, 0.1));
                let shape =
                    format!("{{ type = \"capsule\", radius = {radius:.4}, length = {length:.4} }}");
                (shape, radius + length / 2.0)
            }
            _ => {
                let (major, minor) = (r.range(0.05, 0.08), r.range(0.02, 0.035));
                let shape =
                    format!("{{ type = \"torus\", major = {major:.4}, minor = {minor:.4} }}");
                (shape, major + minor)
            }
        };
        let gap = if r.chance(0.1) {
            -r.range(0.0, 0.5) * size
        } else {
            r.range(0.002, 0.05)
        };
        x += size + if k == 0 { 0.0 } else { gap };
        let backend = r.pick(phyxel::backends::NAMES);
        let spacing = size / r.range(2.5, 4.0);
        let (young, density) = (r.log(1e4, 1e7), r.log(300.0, 5000.0));
        let (poisson, friction) = (r.range(0.0, 0.45), r.range(0.0, 1.0));
        let v = [r.range(-2.0, 2.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0)];
        let rot = [
            r.range(-90.0, 90.0),
            r.range(-90.0, 90.0),
            r.range(-90.0, 90.0),
        ];
        toml += &format!(
            "[[objects]]\nname = \"o{k}\"\nshape = {shape}\nbackend = \"{backend}\"\n\
             spacing = {spacing:.4}\nposition = [{x:.4}, 0.0, 0.0]\n\
             rotation = [{:.1}, {:.1}, {:.1}]\nvelocity = [{:.3}, {:.3}, {:.3}]\n\
             material = {{ young = {young:.4e}, density = {density:.1}, poisson = {poisson:.3}, \
             friction = {friction:.3} }}\n",
            rot[0], rot[1], rot[2], v[0], v[1], v[2]
        );
        x += size;
    }
    // A tool behind the row, driven into it (it moves rigidly at its velocity).
    let tool = r.chance(0.3);
    if tool {
        let speed = r.log(0.2, 2.0);
        let at = -0.3 - 0.03 - r.range(0.0005, 0.003);
        toml += &format!(
            "[[objects]]\nname = \"tool\"\nshape = {{ type = \"sphere\", radius = 0.03 }}\n\
             backend = \"kinematic\"\nspacing = 0.012\nposition = [{at:.4}, 0.0, 0.0]\n\
             velocity = [{speed:.3}, 0.0, 0.0]\nmaterial = {{ young = 1e7 }}\n"
        );
    }
    (toml, gravity || ground || tool)
}

/// Whether the kinematic `tool` (a rigid sphere) may bury itself in body `b`: Hertz's
/// largest indentation of a rigid sphere of radius R into a half-space of modulus
/// `E* = E/(1 − ν²)` by a body of mass m closing at speed v,
/// `δ = (15 m v² / (16 E* √R))^(2/5)` (Johnson, Contact Mechanics, §11.4), exceeds R/2.
/// The closing speed is the tool's x velocity less the body's (all bodies start ahead
/// of it along +x).
fn buries(tool: &phyxel::Object, b: &phyxel::Object) -> bool {
    if b.is_static() {
        return false;
    }
    let radius = 0.03f64;
    let v = (tool.phyxels.vel.get(0).x - b.phyxels.vel.get(0).x).max(0.0) as f64;
    let m = b.phyxels.total_mass();
    let (e, nu) = (b.material.young as f64, b.material.poisson as f64);
    let e_star = e / (1.0 - nu * nu);
    let depth = (15.0 * m * v * v / (16.0 * e_star * radius.sqrt())).powf(0.4);
    depth > 0.5 * radius
}

/// Whether the centre of mass of `a` lies inside body `b`, judged by an independent
/// reference, not the contact pipeline's implicit surface (which is what is under test):
/// the winding number of `b`'s oriented surfels at the point, `w = Σ A_k n_k·(s_k − c) /
/// (4π |s_k − c|³)` with `A_k = π r_k²` (Barill et al. 2018), brute force: about 1
/// inside a closed surface, 0 outside; inside when above 0.6. A static plane is an open
/// surface: a centre below its top within its patch is inside. A torus's centre lies
/// in its hole, not its material: it is not asked.
fn centre_inside(a: &phyxel::Object, b: &phyxel::Object) -> bool {
    let c = a.phyxels.centre_of_mass();
    let c = glam::DVec3::new(c[0], c[1], c[2]);
    let s = &b.surfels;
    let (mut lo, mut hi) = (
        glam::DVec3::splat(f64::INFINITY),
        glam::DVec3::splat(f64::NEG_INFINITY),
    );
    for k in 0..s.pos.len() {
        let p = s.pos.get(k).as_dvec3();
        (lo, hi) = (lo.min(p), hi.max(p));
    }
    if b.is_static() {
        // The soak's static body is the ground plane: surfels on its top face.
        return c.x > lo.x && c.x < hi.x && c.z > lo.z && c.z < hi.z && c.y < hi.y;
    }
    if c.cmplt(lo).any() || c.cmpgt(hi).any() {
        return false;
    }
    let mut w = 0.0f64;
    for k in 0..s.pos.len() {
        let d = s.pos.get(k).as_dvec3() - c;
        let r2 = d.length_squared().max(1e-24);
        let area = std::f64::consts::PI * (s.radius[k] as f64).powi(2);
        w += area * s.normal.get(k).as_dvec3().dot(d) / (r2 * r2.sqrt());
    }
    w / (4.0 * std::f64::consts::PI) > 0.6
}

/// Total momentum (kg m/s) and its scale `Σ m |v|` of the moving objects.
fn momentum(w: &World) -> ([f64; 3], f64) {
    let mut p = [0.0; 3];
    let mut scale = 0.0;
    for o in w.objects.iter().filter(|o| !o.is_static()) {
        let ph = &o.phyxels;
        let q = ph.momentum();
        (0..3).for_each(|c| p[c] += q[c]);
        scale += (0..ph.len())
            .map(|i| ph.mass[i] as f64 * ph.vel.get(i).length() as f64)
            .sum::<f64>();
    }
    (p, scale)
}

#[derive(Default, Debug)]
struct Tally {
    refused: u32,
    finite: u32,
    stopped: u32,
    momentum_checked: u32,
    worst_drift: f64,
    /// Scenes with a kinematic tool that ran, and those whose tool touched a body.
    tools: u32,
    tools_touching: u32,
    /// Tool–body pairs whose Hertz indentation stays below half the tool's radius
    /// (those the pass-through check asks).
    tools_checked: u32,
}

fn run_one(seed: u64, tally: &mut Tally) {
    let (toml, external) = random_scene(seed);
    println!("--- seed {seed}\n{toml}");
    let scene = match Scene::parse(&toml, &format!("soak-{seed}")) {
        Ok(s) => s,
        Err(e) => panic!("seed {seed}: the generator wrote a scene that does not parse: {e}"),
    };
    let mut w = match scene.build(&BuildOptions::default()) {
        Ok(w) => w,
        Err(e) => {
            let m = e.to_string();
            assert!(
                m.contains("objects[") && m.len() > 40,
                "seed {seed}: a refusal must name the object: {m}"
            );
            println!("refused: {m}");
            tally.refused += 1;
            return;
        }
    };
    let (p0, scale) = momentum(&w);
    let torus: Vec<bool> = scene
        .objects
        .iter()
        .map(|o| matches!(o.shape, phyxel::body::shape::Shape::Torus { .. }))
        .collect();
    // Bodies that start inside another (a refused overlap is caught above) are not asked.
    let started_inside =
        |w: &World, i: usize, j: usize| centre_inside(&w.objects[i], &w.objects[j]);
    let n = w.objects.len();
    let mut initially: Vec<bool> = (0..n * n)
        .map(|k| started_inside(&w, k / n, k % n))
        .collect();
    // A rigid tool driven into a soft body may bury itself: where Hertz's indentation
    // of the whole impact reaches past half the tool's radius, the tool's centre inside
    // the body is physics, not a pass-through, and the pair is not asked.
    if let Some(t) = w.objects.iter().position(|o| o.name == "tool") {
        for j in (0..n).filter(|&j| j != t) {
            if buries(&w.objects[t], &w.objects[j]) {
                (initially[t * n + j], initially[j * n + t]) = (true, true);
            } else if !w.objects[j].is_static() {
                tally.tools_checked += 1;
            }
        }
    }
    for s in 1..=scene.steps {
        w.step();
        if w.non_finite.is_some() {
            break;
        }
        if w.objects.len() != n {
            continue; // a fracture renumbers the bodies (the soak's materials do not break)
        }
        for (i, a) in w.objects.iter().enumerate() {
            if a.is_static() || torus[i] {
                continue;
            }
            for (j, b) in w.objects.iter().enumerate() {
                assert!(
                    i == j || initially[i * n + j] || !centre_inside(a, b),
                    "seed {seed}: step {s}: the centre of '{}' ({}) is inside '{}' ({}): \
                     the bodies passed into each other; warnings: {:?}",
                    a.name,
                    a.dynamics.name(),
                    b.name,
                    b.dynamics.name(),
                    w.record.warnings
                );
            }
        }
    }
    match &w.non_finite {
        Some(nf) => {
            let m = nf.to_string();
            assert!(
                m.contains(&format!("step {}", nf.step)) && m.contains(&nf.object),
                "seed {seed}: the non-finite message must name the step and the object: {m}"
            );
            println!("stopped: {m}");
            tally.stopped += 1;
        }
        None => {
            if let Some(t) = w.objects.iter().find(|o| o.name == "tool") {
                tally.tools += 1;
                tally.tools_touching +=
                    w.record
                        .contacts
                        .pairs()
                        .iter()
                        .any(|p| p.a == t.id || p.b == t.id) as u32;
            }
            let finite = w.objects.iter().all(|o| o.phyxels.pos.all_finite());
            assert!(finite, "seed {seed}: non-finite positions without a report");
            tally.finite += 1;
            if !external && scale > 0.0 {
                let (p, _) = momentum(&w);
                let drift = (0..3).map(|c| (p[c] - p0[c]).abs()).fold(0.0, f64::max) / scale;
                tally.momentum_checked += 1;
                tally.worst_drift = tally.worst_drift.max(drift);
                assert!(
                    drift < MOMENTUM_TOLERANCE,
                    "seed {seed}: momentum {p:?} from {p0:?}, drift {drift:.2e} of Σ m|v| = {scale}"
                );
            }
        }
    }
}

/// The pass-through check sees a pass-through: two spheres (R = 0.1 m, 0.1 m apart)
/// closing at 2 m/s stepped at dt = 0.12 s by `mls-implicit` pass through each other
/// (each step closes 0.24 m, more than a sphere; their gap is beyond the solve's gap
/// springs, `solver::springs::margin`, which catch them at dt = 0.05 s), and at some
/// step one centre is inside the other sphere.
#[test]
fn the_pass_through_check_sees_two_spheres_crossing() {
    let scene = Scene::builtin("two-spheres").unwrap();
    let opts = BuildOptions {
        dt: Some(0.12),
        backend: Some("mls-implicit".into()),
        ..Default::default()
    };
    let mut w = scene.build(&opts).unwrap();
    assert!(!centre_inside(&w.objects[0], &w.objects[1]));
    let mut seen = false;
    for _ in 0..6 {
        w.step();
        seen |= centre_inside(&w.objects[0], &w.objects[1]);
        let c = |k: usize| w.objects[k].phyxels.centre_of_mass()[0];
        println!("step {}: centres x {:.4} {:.4}", w.steps, c(0), c(1));
    }
    assert!(seen, "the spheres' centres never entered each other");
    // The world warned of it.
    assert!(
        w.record.warnings.iter().any(|m| m.contains("closed by")),
        "{:?}",
        w.record.warnings
    );
}

#[test]
fn random_scenes_end_finite_or_named_and_keep_momentum() {
    let one: Option<u64> = std::env::var("PHYXEL_SOAK_SEED")
        .ok()
        .and_then(|s| s.parse().ok());
    let count: u64 = std::env::var("PHYXEL_SOAK_SCENES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(SCENES);
    let seeds: Vec<u64> = match one {
        Some(s) => vec![s],
        None => (0..count).map(|k| FIRST_SEED + k).collect(),
    };
    let mut tally = Tally::default();
    for &seed in &seeds {
        run_one(seed, &mut tally);
    }
    println!("{} scenes: {tally:?}", seeds.len());
    if one.is_none() {
        assert!(
            tally.finite as u64 > count / 2,
            "most scenes must build and run: {tally:?}"
        );
        assert!(tally.momentum_checked > 20, "{tally:?}");
        assert!(
            tally.tools_touching > 5,
            "tools must reach the bodies: {tally:?}"
        );
        assert!(
            tally.tools_checked > 20,
            "the check must ask tool pairs: {tally:?}"
        );
    }
}
