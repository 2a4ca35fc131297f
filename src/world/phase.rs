//! The one phase list of the step ([`Phase::ALL`]: the step's order, the timing table's
//! rows, the flamegraph's frame names) and the per-phase wall-clock timers.

use std::time::{Duration, Instant};

/// The phases of one step (paper section 8, `animate`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Phase {
    Dynamics,
    Advect,
    BroadPhase,
    Grids,
    Detect,
    ContactSurface,
    Resample,
    Forces,
    Distribute,
    Springs,
    SelfCollision,
    Topology,
}

impl Phase {
    /// Every phase, in the order the step runs them.
    pub const ALL: [Phase; 12] = [
        Phase::Dynamics,
        Phase::Advect,
        Phase::BroadPhase,
        Phase::Grids,
        Phase::Detect,
        Phase::ContactSurface,
        Phase::Resample,
        Phase::Forces,
        Phase::Distribute,
        Phase::Springs,
        Phase::SelfCollision,
        Phase::Topology,
    ];

    /// Renamed [`Phase::Grids`]: the phase builds the phyxel grids too.
    #[deprecated(note = "use Phase::Grids")]
    #[allow(non_upper_case_globals)]
    pub const SurfelGrid: Phase = Phase::Grids;

    /// The phase's name (the name of the function that runs it).
    pub fn name(self) -> &'static str {
        match self {
            Phase::Dynamics => "dynamics",
            Phase::Advect => "advect",
            Phase::BroadPhase => "broad_phase",
            Phase::Grids => "grids",
            Phase::Detect => "detect",
            Phase::ContactSurface => "contact_surface",
            Phase::Resample => "resample",
            Phase::Forces => "forces",
            Phase::Distribute => "distribute",
            Phase::Springs => "springs",
            Phase::SelfCollision => "self_collision",
            Phase::Topology => "topology",
        }
    }
}

/// Accumulated time and work items per phase.
#[derive(Clone, Debug, Default)]
pub struct PhaseTimes {
    time: [Duration; Phase::ALL.len()],
    /// Work items per phase, as each phase counts them (phyxels stepped, pairs found,
    /// points gridded, surfels tested, contact surfels, springs, phyxels checked; 0
    /// where none).
    work: [u64; Phase::ALL.len()],
}

impl PhaseTimes {
    /// Runs `f`, adding its wall time to `phase`.
    #[inline]
    pub fn time<R>(&mut self, phase: Phase, f: impl FnOnce() -> R) -> R {
        let t = Instant::now();
        let r = f();
        self.time[phase as usize] += t.elapsed();
        r
    }

    pub fn add_work(&mut self, phase: Phase, items: u64) {
        self.work[phase as usize] += items;
    }

    pub fn seconds(&self, phase: Phase) -> f64 {
        self.time[phase as usize].as_secs_f64()
    }

    pub fn work(&self, phase: Phase) -> u64 {
        self.work[phase as usize]
    }

    pub fn total_seconds(&self) -> f64 {
        self.time.iter().map(Duration::as_secs_f64).sum()
    }
}
