//! The two cases every engine of the peer bench runs, their references, and the record
//! each run prints (one JSON object per line). The engines' own set-ups live in
//! `benches/peers.rs` (phyxel and Rapier) and `splishsplash.py` (SPlisHSPlasH); the
//! chart in `src/bin/chart.rs`.

use serde_json::{Value, json};

/// The cantilever: a 1.0 × 0.1 × 0.1 m bar along x centred at the origin, clamped over
/// x < −0.45 m, bending under gravity (phyxel's built-in `cantilever` scene).
pub mod cantilever {
    pub const LENGTH: f64 = 1.0;
    pub const THICKNESS: f64 = 0.1;
    /// Length held by the clamp at x = −0.5 m (m).
    pub const CLAMP: f64 = 0.05;
    pub const DENSITY: f64 = 1000.0;
    pub const YOUNG: f64 = 1.0e8;
    pub const POISSON: f64 = 0.3;
    pub const GRAVITY: f64 = 9.81;

    /// Euler–Bernoulli's static tip deflection `q L⁴/(8 E I)` (m, downwards), q = ρ g b t,
    /// I = b t³/12, L the free length: 11.99 mm.
    pub fn euler_bernoulli_tip() -> f64 {
        let (l, t) = (LENGTH - CLAMP, THICKNESS);
        let q = DENSITY * GRAVITY * t * t;
        let i = t.powi(4) / 12.0;
        q * l.powi(4) / (8.0 * YOUNG * i)
    }

    /// The first mode's period (s): `2π / (1.875² √(EI/(ρ A L⁴)))`, 0.177 s.
    pub fn period() -> f64 {
        let (l, t) = (LENGTH - CLAMP, THICKNESS);
        let i = t.powi(4) / 12.0;
        let w = 1.875f64.powi(2) * (YOUNG * i / (DENSITY * t * t * l.powi(4))).sqrt();
        2.0 * std::f64::consts::PI / w
    }
}

/// The contact case: an elastic ball thrown at a static box, no gravity. Its reference is
/// Hertz's impact of a sphere on a rigid half-space (Johnson, Contact Mechanics, §11.4):
/// contact time `t_c = 2.868 (m²/(R E*² v))^{1/5}`, E* = E/(1 − ν²). Hertz is
/// quasi-static: here t_c (35.5 ms) is 5.6 times the ball's longitudinal wave transit
/// 2R/c (6.3 ms), and v/c = 1.6%.
pub mod ball {
    pub const RADIUS: f64 = 0.1;
    pub const DENSITY: f64 = 1000.0;
    pub const YOUNG: f64 = 1.0e6;
    pub const POISSON: f64 = 0.3;
    /// Impact speed (m/s, downwards).
    pub const SPEED: f64 = 0.5;
    /// Gap between the ball and the box's top face (y = 0) at the start (m): SPlisHSPlasH's
    /// boundary reaches two particle spacings (up to 25 mm) out.
    pub const GAP: f64 = 0.03;
    /// Simulated time of a run (s): the approach (60 ms), the contact and 64 ms after.
    pub const DURATION: f64 = 0.16;

    pub fn mass() -> f64 {
        DENSITY * 4.0 / 3.0 * std::f64::consts::PI * RADIUS.powi(3)
    }

    /// Hertz's contact time (s).
    pub fn hertz_contact_time() -> f64 {
        let e_star = YOUNG / (1.0 - POISSON * POISSON);
        2.868 * (mass().powi(2) / (RADIUS * e_star * e_star * SPEED)).powf(0.2)
    }
}

/// Reads the contact out of the ball's centre-of-mass velocity: with no gravity it
/// changes only while the ball touches the box.
#[derive(Default)]
pub struct ContactTimer {
    /// (time at the step's end, vertical centre-of-mass velocity, centre height).
    samples: Vec<(f64, f64, f64)>,
}

/// What [`ContactTimer`] found.
pub struct Contact {
    /// Contact time (s): from the first to the last step whose centre-of-mass
    /// acceleration exceeds 0.1% of the peak. Hertz's force, about `F_max sin^{3/2}(π t/t_c)`,
    /// is under that threshold for 0.3% of t_c at each end, so the rule reads 0.6% short.
    pub time: f64,
    /// Rebound speed over impact speed.
    pub restitution: f64,
    /// Lowest centre height (m; the box's top face is y = 0).
    pub lowest: f64,
}

impl ContactTimer {
    /// Records the state after a step ending at `time` (s).
    pub fn push(&mut self, time: f64, vy: f64, y: f64) {
        self.samples.push((time, vy, y));
    }

    /// The last vertical velocity (m/s) and the lowest centre height (m): what a run
    /// without a contact pulse did instead (never reached the box, or never left it).
    pub fn trace(&self) -> Option<(f64, f64)> {
        Some((self.samples.last()?.1, self.lowest()))
    }

    /// Lowest centre height over the run (m).
    fn lowest(&self) -> f64 {
        self.samples.iter().map(|s| s.2).fold(f64::MAX, f64::min)
    }

    /// The contact, `None` if the ball never touched or never left.
    pub fn contact(&self, v_in: f64) -> Option<Contact> {
        let mut prev = (0.0, v_in);
        let acc: Vec<(f64, f64)> = self
            .samples
            .iter()
            .map(|&(t, v, _)| {
                let a = (v - prev.1) / (t - prev.0);
                let step = t - prev.0;
                prev = (t, v);
                (a.abs(), step)
            })
            .collect();
        let peak = acc.iter().map(|a| a.0).fold(0.0, f64::max);
        let on = |a: &(f64, f64)| a.0 > 1e-3 * peak;
        let first = acc.iter().position(on)?;
        let last = acc.iter().rposition(on)?;
        if peak == 0.0 || last + 1 == acc.len() {
            return None;
        }
        Some(Contact {
            time: acc[first..=last].iter().map(|a| a.1).sum(),
            restitution: self.samples.last()?.1 / -v_in,
            lowest: self.lowest(),
        })
    }
}

/// One run's record: the chart's point and the facts to reproduce it.
pub struct Record {
    pub engine: &'static str,
    /// Backend, solver or method within the engine.
    pub method: String,
    pub case: &'static str,
    /// Nodes, phyxels or particles through the bar's thickness, or per ball radius.
    pub resolution: f64,
    /// Simulated points of the moving body.
    pub points: usize,
    pub threads: usize,
    pub dt: f64,
    /// Simulated time the timing covers (s).
    pub sim_time: f64,
    /// Wall seconds spent stepping it (set-up excluded).
    pub wall: f64,
    pub measured: f64,
    pub reference: f64,
    /// Case-specific facts.
    pub extra: Value,
}

impl Record {
    /// The JSON line: the record plus `wall_per_sim` and the signed relative `error`.
    pub fn json(&self) -> Value {
        json!({
            "engine": self.engine, "method": self.method, "case": self.case,
            "resolution": self.resolution, "points": self.points, "threads": self.threads,
            "dt": self.dt, "wall": self.wall, "sim_time": self.sim_time,
            "wall_per_sim": self.wall / self.sim_time, "measured": self.measured,
            "reference": self.reference,
            "error": (self.measured - self.reference) / self.reference,
            "extra": self.extra,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The references' numbers, by hand: δ = 98.1 · 0.95⁴ / (8 · 1e8 · 8.333e-6) m and
    /// t_c = 2.868 (4.18879² / (0.1 · 1.0989e6² · 0.5))^{1/5} s.
    #[test]
    fn references() {
        assert!((cantilever::euler_bernoulli_tip() - 0.011986).abs() < 1e-6);
        assert!((ball::hertz_contact_time() - 0.03552).abs() < 1e-4);
    }

    /// A half-sine force pulse of known length is timed within the stated bias.
    #[test]
    fn timer_reads_a_half_sine_pulse() {
        let (tc, dt, v) = (0.035, 1e-5, -0.5);
        let mut timer = ContactTimer::default();
        let (mut vy, mut t) = (v, 0.0);
        while t < 0.1 {
            let s = (t - 0.01) / tc;
            let a = if (0.0..1.0).contains(&s) {
                // Reverses v over the pulse: ∫ a = 1.0 m/s.
                std::f64::consts::PI / (2.0 * tc) * (std::f64::consts::PI * s).sin()
            } else {
                0.0
            };
            vy += a * dt;
            t += dt;
            timer.push(t, vy, 0.0);
        }
        let c = timer.contact(v).unwrap();
        assert!((c.time / tc - 1.0).abs() < 0.005, "{}", c.time);
        assert!((c.restitution - 1.0).abs() < 1e-3);
    }
}
