//! The world and its step, read like the paper's `animate` (Keiser et al. 2004, §8).

use crate::dynamics::StepContext;
use crate::object::Object;
use crate::timing::{Phase, PhaseTimes};
use glam::Vec3;
use rayon::prelude::*;

/// All objects of a scene and the state of the run.
pub struct World {
    pub objects: Vec<Object>,
    /// Gravitational acceleration (m/s²).
    pub gravity: Vec3,
    /// Time step (s).
    pub dt: f32,
    /// Steps taken so far.
    pub steps: u64,
    /// Wall time and work per phase, summed over the run.
    pub times: PhaseTimes,
    /// Largest signed penetration depth of a colliding surfel over the run (m).
    pub max_penetration: f32,
}

impl World {
    pub fn new(objects: Vec<Object>, gravity: Vec3, dt: f32) -> Self {
        Self {
            objects,
            gravity,
            dt,
            steps: 0,
            times: PhaseTimes::default(),
            max_penetration: 0.0,
        }
    }

    /// Largest stable time step over all objects (s) and the object that limits it.
    pub fn stable_dt(&self) -> (f32, Option<&Object>) {
        self.objects
            .iter()
            .map(|o| (o.dynamics.stable_dt(&o.phyxels, &o.material), o))
            .fold((f32::INFINITY, None), |acc, (dt, o)| {
                if dt < acc.0 { (dt, Some(o)) } else { acc }
            })
    }

    /// One time step: dynamics, surfel advection, then contact handling.
    pub fn step(&mut self) {
        let mut t = std::mem::take(&mut self.times);
        t.time(Phase::Dynamics, || self.dynamics());
        t.add_work(Phase::Dynamics, self.moving_phyxels());
        t.time(Phase::Advect, || self.advect());
        t.time(Phase::BroadPhase, || self.broad_phase());
        t.time(Phase::SurfelGrid, || self.surfel_grid());
        t.time(Phase::Detect, || self.detect());
        t.time(Phase::ContactSurface, || self.contact_surface());
        t.time(Phase::Resample, || self.resample());
        t.time(Phase::Forces, || self.forces());
        t.time(Phase::Distribute, || self.distribute());
        t.time(Phase::Topology, || self.topology());
        self.times = t;
        self.steps += 1;
    }

    fn moving_phyxels(&self) -> u64 {
        self.objects
            .iter()
            .filter(|o| !o.is_static())
            .map(|o| o.phyxels.len() as u64)
            .sum()
    }

    /// Each non-static object's backend advances its phyxels.
    fn dynamics(&mut self) {
        let (dt, gravity) = (self.dt, self.gravity);
        self.objects
            .par_iter_mut()
            .filter(|o| !o.is_static())
            .for_each(|o| {
                let ctx = StepContext::new(dt, gravity, &o.material);
                o.dynamics.step(&mut o.phyxels, &ctx);
            });
    }

    /// Surfels follow the phyxels of their object.
    fn advect(&mut self) {
        self.objects
            .par_iter_mut()
            .filter(|o| !o.is_static())
            .for_each(|o| o.advect_surfels());
    }

    /// Overlapping surfel bounding boxes. Lands with the collision-detection issue.
    fn broad_phase(&mut self) {}

    /// Per-object surfel grids. Lands with the collision-detection issue.
    fn surfel_grid(&mut self) {}

    /// Colliding surfels. Lands with the collision-detection issue.
    fn detect(&mut self) {}

    /// Colliding surfels moved onto the contact surface. Lands with the contact issue.
    fn contact_surface(&mut self) {}

    /// Even resampling of the contact surface. Lands with the contact issue.
    fn resample(&mut self) {}

    /// Penalty and friction forces on contact surfels. Lands with the contact issue.
    fn forces(&mut self) {}

    /// Contact forces spread onto phyxels. Lands with the contact issue.
    fn distribute(&mut self) {}

    /// Fracture and self-collision. Lands with the topology issue.
    fn topology(&mut self) {}

    /// Total linear momentum of all objects (kg·m/s).
    pub fn momentum(&self) -> [f64; 3] {
        let mut p = [0.0; 3];
        for o in self.objects.iter().filter(|o| !o.is_static()) {
            let q = o.phyxels.momentum();
            (0..3).for_each(|k| p[k] += q[k]);
        }
        p
    }

    /// True when every phyxel and surfel is finite.
    pub fn all_finite(&self) -> bool {
        self.objects
            .iter()
            .all(|o| o.phyxels.all_finite() && o.surfels.all_finite())
    }
}
