//! `phyxel view --input events.toml`: scripted input, applied by the simulation thread
//! before the step it names, so that a scripted session is the same at any frame rate
//! (the tests drive the tool with it). Each `[[event]]` has a `step` and one action:
//!
//! ```toml
//! [[event]]
//! step = 0
//! tool = [0.0, 0.3, 0.0]                         # show the tool, send it here (m)
//! [[event]]
//! step = 400
//! remove_tool = true
//! [[event]]
//! step = 500
//! grab = { eye = [0.0, 1.0, 2.0], at = [0.0, 0.1, 0.0] }   # as a click on the ray
//! [[event]]
//! step = 510
//! drag = { eye = [0.0, 1.0, 2.0], at = [0.3, 0.4, 0.0] }
//! [[event]]
//! step = 520
//! release = true                                 # a throw, if still moving
//! ```
//!
//! Other actions: `drop = [x, y, z]` (a new sphere), `gravity = false`, `speed = 0.5`,
//! `pause = true` (toggles), `phyxels = true`, `pressure = true`, `arrows = true`.

use super::sim::Command;
use glam::Vec3;
use serde::Deserialize;
use std::path::Path;

/// Largest coordinate (m) a script may name: far beyond any scene, and small enough that
/// differences of coordinates stay finite in f32.
const MAX_COORDINATE: f32 = 1e6;

/// Slowest pace (simulated seconds per wall second) `--speed` and a script's `speed`
/// take: slower, a step waits hours (a speed of 1e-39 never reached its next step, so a
/// screenshot run never ended). Pausing is the way to stop time.
pub(crate) const MIN_SPEED: f64 = 1e-3;

/// Checks a pace: 0 (as fast as it steps) or finite and at least [`MIN_SPEED`]. The
/// message names no option; the caller prefixes it.
pub(crate) fn check_speed(s: f64) -> Result<(), String> {
    if s == 0.0 || (s.is_finite() && s >= MIN_SPEED) {
        Ok(())
    } else {
        Err(format!(
            "must be 0 (as fast as it steps) or finite and ≥ {MIN_SPEED:e} (to stop time, pause)"
        ))
    }
}

/// A ray as a script writes it: from `eye` through `at`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Ray {
    eye: [f32; 3],
    at: [f32; 3],
}

/// One `[[event]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Event {
    step: u64,
    tool: Option<[f32; 3]>,
    remove_tool: Option<bool>,
    grab: Option<Ray>,
    drag: Option<Ray>,
    release: Option<bool>,
    drop: Option<[f32; 3]>,
    gravity: Option<bool>,
    speed: Option<f64>,
    pause: Option<bool>,
    phyxels: Option<bool>,
    pressure: Option<bool>,
    arrows: Option<bool>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default)]
    event: Vec<Event>,
}

/// The events of a script, in step order, and how many have been applied.
#[derive(Clone, Debug, Default)]
pub(crate) struct Script {
    events: Vec<(u64, Command)>,
    next: usize,
}

/// The unit ray of a script's `eye` and `at`, or why not.
fn ray(r: &Ray, what: &str) -> Result<Command, String> {
    let (eye, at) = (Vec3::from(r.eye), Vec3::from(r.at));
    let d = (at - eye).normalize_or_zero();
    // `is_finite` first: `max_element` passes NaN by.
    let bounded = |p: Vec3| p.is_finite() && p.abs().max_element() <= MAX_COORDINATE;
    if !(bounded(eye) && bounded(at)) || d == Vec3::ZERO {
        return Err(format!(
            "{what}: eye {eye} and at {at} must be distinct, within ±{MAX_COORDINATE:e} m"
        ));
    }
    Ok(if what == "grab" {
        Command::Grab(eye, d)
    } else {
        Command::DragTo(eye, d)
    })
}

impl Event {
    /// The event's command, or why it has none or several.
    fn command(&self) -> Result<Command, String> {
        let point = |p: [f32; 3], what: &str| {
            let v = Vec3::from(p);
            if v.is_finite() && v.abs().max_element() <= MAX_COORDINATE {
                Ok(v)
            } else {
                Err(format!(
                    "{what} = {p:?}: must be within ±{MAX_COORDINATE:e} m"
                ))
            }
        };
        for (key, value, meaning) in [
            ("pause", self.pause, "toggles pause"),
            ("release", self.release, "lets go"),
            ("remove_tool", self.remove_tool, "removes the tool"),
        ] {
            if value == Some(false) {
                return Err(format!(
                    "{key} = false does nothing: `{key} = true` {meaning}; leave the event out"
                ));
            }
        }
        let mut found = Vec::new();
        if let Some(p) = self.tool {
            found.push(Command::Tool(Some(point(p, "tool")?)));
        }
        if self.remove_tool == Some(true) {
            found.push(Command::Tool(None));
        }
        if let Some(r) = &self.grab {
            found.push(ray(r, "grab")?);
        }
        if let Some(r) = &self.drag {
            found.push(ray(r, "drag")?);
        }
        if self.release == Some(true) {
            found.push(Command::Release);
        }
        if let Some(p) = self.drop {
            found.push(Command::Drop(Some(point(p, "drop")?)));
        }
        if let Some(g) = self.gravity {
            found.push(Command::Gravity(g));
        }
        if let Some(s) = self.speed {
            check_speed(s).map_err(|m| format!("speed = {s}: {m}"))?;
            found.push(Command::Speed(s));
        }
        if self.pause == Some(true) {
            found.push(Command::TogglePause);
        }
        if let Some(on) = self.phyxels {
            found.push(Command::ShowPhyxels(on));
        }
        if let Some(on) = self.pressure {
            found.push(Command::Pressure(on));
        }
        if let Some(on) = self.arrows {
            found.push(Command::Arrows(on));
        }
        match found.len() {
            1 => Ok(found.remove(0)),
            0 => Err(
                "no action (tool, remove_tool, grab, drag, release, drop, gravity, \
                      speed, pause, phyxels, pressure, arrows)"
                    .into(),
            ),
            n => Err(format!("{n} actions: give each its own [[event]]")),
        }
    }
}

impl Script {
    /// Reads an event script; errors name the file and the event.
    pub(crate) fn load(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Self::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// Parses an event script (the text of [`Script::load`]).
    pub(crate) fn parse(text: &str) -> Result<Self, String> {
        let file: File = toml::from_str(text).map_err(|e| e.to_string())?;
        let mut events = Vec::with_capacity(file.event.len());
        for (k, e) in file.event.iter().enumerate() {
            let c = e
                .command()
                .map_err(|m| format!("event[{k}] (step {}): {m}", e.step))?;
            events.push((e.step, c));
        }
        // Stable: events of one step keep the file's order.
        events.sort_by_key(|e| e.0);
        Ok(Self { events, next: 0 })
    }

    /// Starts the script again (the scene was rebuilt).
    pub(crate) fn rewind(&mut self) {
        self.next = 0;
    }

    /// The commands due before step `step` that have not been applied yet.
    pub(crate) fn due(&mut self, step: u64) -> Vec<Command> {
        let start = self.next;
        while self.next < self.events.len() && self.events[self.next].0 <= step {
            self.next += 1;
        }
        self.events[start..self.next]
            .iter()
            .map(|e| e.1.clone())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_come_due_in_step_order() {
        let mut s = Script::parse(
            "[[event]]\nstep = 5\nrelease = true\n[[event]]\nstep = 0\ntool = [0, 1, 0]\n\
             [[event]]\nstep = 5\ngravity = false\n",
        )
        .unwrap();
        assert_eq!(s.due(0), vec![Command::Tool(Some(Vec3::Y))]);
        assert!(s.due(4).is_empty());
        assert_eq!(s.due(9), vec![Command::Release, Command::Gravity(false)]);
        assert!(s.due(10).is_empty());
        s.rewind();
        assert_eq!(s.due(100).len(), 3);
    }

    #[test]
    fn bad_events_are_named() {
        let two = Script::parse("[[event]]\nstep = 3\nrelease = true\ngravity = true\n");
        assert_eq!(
            two.unwrap_err(),
            "event[0] (step 3): 2 actions: give each its own [[event]]"
        );
        let none = Script::parse("[[event]]\nstep = 1\n").unwrap_err();
        assert!(none.starts_with("event[0] (step 1): no action"), "{none}");
        let ray = Script::parse("[[event]]\nstep = 1\ngrab = { eye = [0,0,0], at = [0,0,0] }\n");
        assert!(ray.unwrap_err().contains("must be distinct"));
        let far = Script::parse("[[event]]\nstep = 1\ndrop = [1e30, 0, 0]\n").unwrap_err();
        assert!(far.contains("within"), "{far}");
        let off = Script::parse("[[event]]\nstep = 1\npause = false\n").unwrap_err();
        assert!(off.contains("pause = true` toggles pause"), "{off}");
        let unknown = Script::parse("[[event]]\nstep = 1\nteleport = true\n").unwrap_err();
        assert!(unknown.contains("teleport"), "{unknown}");
    }
}
