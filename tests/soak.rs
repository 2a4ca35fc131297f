//! Random-scene soak: a few hundred scenes of random shapes, materials, velocities,
//! placements (some overlapping) and backends, within the validated ranges, each built
//! and stepped 100–200 times at its default dt. Every scene either is refused with a
//! message, or runs to the end finite, or stops with a named non-finite message; none
//! panics. Where no external force acts (no gravity, no static body), the total
//! momentum stays the initial one within [`MOMENTUM_TOLERANCE`] of the momentum scale.
//!
//! Every scene is printed (seed and TOML) before it runs, so a failure shows what to
//! rerun: `PHYXEL_SOAK_SEED=<seed> cargo test --release --test soak -- --nocapture`
//! runs that one scene; `PHYXEL_SOAK_SCENES=N` sets how many (default [`SCENES`]).

use phyxel::World;
use phyxel::scene::{BuildOptions, Scene};

/// Scenes per run (about 40 s on two cores).
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

/// One random scene as TOML, and whether an external force acts (gravity or a static
/// body).
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
    (toml, gravity || ground)
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
    for _ in 0..scene.steps {
        w.step();
        if w.non_finite.is_some() {
            break;
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
    }
}
