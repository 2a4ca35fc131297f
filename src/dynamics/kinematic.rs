//! A kinematic body: a rigid object whose motion is prescribed, not computed. It is the
//! paper's user-guided tool (a probe pressed into soft tissue, a finger, a pusher): the
//! contact pipeline treats it like any other object, so the bodies it touches feel
//! penalty and friction forces, while the forces it receives move nothing and are summed
//! as the [`Kinematic::reaction`] (what a haptic device would render).
//!
//! Drive it through the library: `object.dynamics_mut::<Kinematic>()` gives the backend,
//! whose `target` (where the body's centre should go, reached at `max_speed` at most)
//! or `velocity` (when no target is set) the caller changes between steps.

use crate::dynamics::{Dynamics, StepContext};
use crate::material::Material;
use crate::points::phyxels::Phyxels;
use glam::{Mat3, Vec3};

/// Name of the kinematic backend in scenes (`backend = "kinematic"`).
pub const NAME: &str = "kinematic";

/// Speed limit (m/s) of a new kinematic body moving to a target: fast enough to follow a
/// hand, slow enough that a body met at the stable dt of a soft scene (1e-4 s) is entered
/// by 0.2 mm per step, not jumped through.
pub const DEFAULT_MAX_SPEED: f32 = 2.0;

/// A rigid body moved by the caller (translation only).
#[derive(Clone, Debug)]
pub struct Kinematic {
    /// Velocity (m/s) of the body while no `target` is set; a scene's `velocity`.
    pub velocity: Vec3,
    /// Where the body's centre of mass should go (m). The body moves straight towards
    /// it, at most `max_speed` per second, and stops there.
    pub target: Option<Vec3>,
    /// Speed limit (m/s) of the motion towards `target`.
    pub max_speed: f32,
    reaction: Vec3,
    centre: Vec3,
    /// Energy the prescribed motion has supplied (J): see [`Kinematic::supplied`].
    supplied: f64,
    /// Velocity of the last step (m/s), for the change of the body's own kinetic energy.
    last_velocity: Vec3,
    /// ∇u of a translation: zero for every phyxel (surfels are advected without the
    /// core's MLS estimate).
    zero_gradient: Vec<Mat3>,
}

impl Kinematic {
    /// A kinematic body for `phyxels`, moving with their mean velocity (the scene's
    /// `velocity`) until given a target.
    pub fn new(phyxels: &Phyxels) -> Self {
        let n = phyxels.len().max(1) as f32;
        let velocity = phyxels.vel.iter().fold(Vec3::ZERO, |a, v| a + v) / n;
        Self {
            velocity,
            target: None,
            max_speed: DEFAULT_MAX_SPEED,
            reaction: Vec3::ZERO,
            centre: centre_of_mass(phyxels),
            supplied: 0.0,
            last_velocity: velocity,
            zero_gradient: vec![Mat3::ZERO; phyxels.len()],
        }
    }

    /// Total external force (N) the body received during the last step: contact
    /// forces and its `load`, but not gravity, which moves nothing here either.
    pub fn reaction(&self) -> Vec3 {
        self.reaction
    }

    /// Energy the prescribed motion has put into the world so far (J): the work of the
    /// forces the body exerts on others (`−reaction · v dt` per step) plus the change of
    /// its own kinetic and gravitational energy. An energy balance of the world subtracts it: the motion is
    /// a load, not a numerical gain.
    pub fn supplied(&self) -> f64 {
        self.supplied
    }

    /// The body's centre of mass after the last step (m).
    pub fn centre(&self) -> Vec3 {
        self.centre
    }
}

/// Mass-weighted mean of the free phyxels' positions (all of them when every one is
/// fixed).
fn centre_of_mass(p: &Phyxels) -> Vec3 {
    let free = |i: usize| p.fixed[i] == 0;
    let any_free = (0..p.len()).any(free);
    let (mut sum, mut mass) = (Vec3::ZERO, 0.0f32);
    for i in (0..p.len()).filter(|&i| free(i) || !any_free) {
        sum += p.mass[i] * p.pos.get(i);
        mass += p.mass[i];
    }
    if mass > 0.0 { sum / mass } else { Vec3::ZERO }
}

impl Dynamics for Kinematic {
    fn name(&self) -> &str {
        NAME
    }

    /// Moves every free phyxel by the same displacement and sets its velocity to the
    /// body's; the forces received are summed into the reaction and cleared.
    fn step(&mut self, phyxels: &mut Phyxels, ctx: &StepContext<'_>) {
        let dt = ctx.dt;
        let c = centre_of_mass(phyxels);
        let v = match self.target {
            Some(t) if dt > 0.0 => {
                let to_go = t - c;
                let reach = self.max_speed * dt;
                let step = if to_go.length() > reach {
                    to_go * (reach / to_go.length())
                } else {
                    to_go
                };
                step / dt
            }
            Some(_) => Vec3::ZERO,
            None => self.velocity,
        };
        let mut reaction = Vec3::ZERO;
        for i in 0..phyxels.len() {
            if phyxels.fixed[i] != 0 {
                continue;
            }
            reaction += phyxels.force.get(i);
            phyxels.pos.add(i, v * dt);
            phyxels.vel.set(i, v);
        }
        phyxels.force.fill_zero();
        self.reaction = reaction;
        let mass: f32 = (0..phyxels.len())
            .filter(|&i| phyxels.fixed[i] == 0)
            .map(|i| phyxels.mass[i])
            .sum();
        // Its own kinetic and potential (−m g·x) energy change, and the work on others.
        let kinetic =
            0.5 * mass as f64 * (v.length_squared() - self.last_velocity.length_squared()) as f64;
        let potential = -(mass * ctx.gravity.dot(v) * dt) as f64;
        self.supplied += kinetic + potential - (reaction.dot(v) * dt) as f64;
        self.last_velocity = v;
        self.velocity = if self.target.is_some() { Vec3::ZERO } else { v };
        self.centre = c + v * dt;
        if self.zero_gradient.len() != phyxels.len() {
            self.zero_gradient = vec![Mat3::ZERO; phyxels.len()];
        }
    }

    /// Nothing integrates, so nothing bounds the step, its contacts included
    /// ([`Dynamics::is_prescribed`]); the bodies it touches keep their own bounds.
    fn stable_dt(&self, _phyxels: &Phyxels, _material: &Material) -> f32 {
        f32::INFINITY
    }

    fn displacement_gradient(&self) -> Option<&[Mat3]> {
        Some(&self.zero_gradient)
    }

    fn is_prescribed(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube() -> Phyxels {
        let pts: Vec<Vec3> = (0..27)
            .map(|k| Vec3::new((k % 3) as f32, (k / 3 % 3) as f32, (k / 9) as f32) * 0.1)
            .collect();
        Phyxels::at_rest(&pts, 1e-3, 1000.0)
    }

    /// A target is reached in a straight line at `max_speed` and then held: the centre
    /// after n steps is exact up to f32 round-off of the positions (1e-6 m).
    #[test]
    fn moves_to_target_at_max_speed_then_stops() {
        let mut p = cube();
        let mut k = Kinematic::new(&p);
        let start = k.centre();
        k.target = Some(start + Vec3::new(0.3, 0.0, 0.0));
        k.max_speed = 1.0;
        let m = Material::default();
        let ctx = StepContext::new(0.01, Vec3::new(0.0, -9.81, 0.0), &m);
        for _ in 0..10 {
            k.step(&mut p, &ctx);
        }
        // 10 steps × 0.01 s × 1 m/s = 0.1 m of the 0.3 m, gravity ignored.
        assert!((k.centre() - start - Vec3::new(0.1, 0.0, 0.0)).length() < 1e-6);
        assert!((p.vel.get(0) - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-5);
        for _ in 0..40 {
            k.step(&mut p, &ctx);
        }
        assert!((centre_of_mass(&p) - start - Vec3::new(0.3, 0.0, 0.0)).length() < 1e-5);
        assert_eq!(p.vel.get(5), Vec3::ZERO);
    }

    /// The supplied energy is the work against the received force plus the body's own
    /// energy change: pushed back by 2 N while moving at 1 m/s for 0.5 s against no
    /// gravity, then brought to rest: 1 J of work, and ½ m v² = 13.5 J (27 kg cube)
    /// gained and given back.
    #[test]
    fn supplied_energy_is_work_plus_own_energy() {
        let mut p = cube();
        let mass: f32 = p.mass[..p.len()].iter().sum();
        let mut k = Kinematic::new(&p);
        let m = Material::default();
        let ctx = StepContext::new(0.5, Vec3::ZERO, &m);
        k.velocity = Vec3::X;
        p.force.add(0, Vec3::new(-2.0, 0.0, 0.0));
        k.step(&mut p, &ctx);
        let kinetic = 0.5 * mass as f64;
        assert!(
            (k.supplied() - (1.0 + kinetic)).abs() < 1e-4,
            "{}",
            k.supplied()
        );
        k.velocity = Vec3::ZERO;
        k.step(&mut p, &ctx);
        assert!((k.supplied() - 1.0).abs() < 1e-4, "{}", k.supplied());
    }

    /// The forces put on the phyxels between steps come back as the reaction (their
    /// sum, exactly in this order) and are cleared; fixed phyxels stay where they are.
    #[test]
    fn reaction_is_the_sum_of_received_forces() {
        let mut p = cube();
        p.fixed[0] = 1;
        let mut k = Kinematic::new(&p);
        k.velocity = Vec3::new(0.0, 0.0, 2.0);
        p.force.add(3, Vec3::new(1.0, 2.0, 0.0));
        p.force.add(7, Vec3::new(0.5, -2.0, 4.0));
        let m = Material::default();
        let before = p.pos.get(0);
        k.step(&mut p, &StepContext::new(0.5, Vec3::ZERO, &m));
        assert_eq!(k.reaction(), Vec3::new(1.5, 0.0, 4.0));
        assert!(p.force.iter().all(|f| f == Vec3::ZERO));
        assert_eq!(p.pos.get(0), before);
        assert_eq!(p.pos.get(1).z - cube().pos.get(1).z, 1.0);
    }
}
