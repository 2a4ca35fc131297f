//! What a scene may do that the method cannot serve well: built anyway, with a
//! warning that names the object and the knob (docs/SCENES.md, "Limits").

use super::*;

impl Scene {
    /// Pairs of objects whose start velocities close them faster than the slower P-wave
    /// speed of the two materials (along the line between their centres): penalty
    /// contact holds impacts up to about that speed (`two-spheres`, c = 11.6 m/s: 12
    /// m/s closing bounces, 14 m/s passes through with the default `contact_stiffness`),
    /// and a pass-through loses no energy, so the energy check cannot see it.
    /// Pairs whose start velocities close them so fast that the penalty spring needs
    /// more than [`IMPACT_DEPTH_WARNING`] of the thinner body's thickness scale `3V/A`
    /// to stop them (head-on along the line between their centres, as
    /// `fast_approaches`). Stopping depth of a body of curvature radius R (the smaller moving
    /// body's `3V/A`, its radius for a sphere) on the spring `k` per area
    /// ([`crate::contact::params::contact_params`]): `½ μ v² = ⅔ π R k d³` (the contact disc's area
    /// `2π R d`), μ the pair's reduced mass (the moving body's mass against a static
    /// one). A 5 cm ball at 100 m/s needs 2.6 cm, and passes through a 1 cm static wall
    /// with every value finite and no other warning. Planes (no volume) count as thick.
    pub(super) fn deep_impacts(&self, objects: &[Object]) -> Vec<String> {
        let thickness = |i: usize| thickness_scale(&self.objects[i].shape).unwrap_or(f64::INFINITY);
        let mut out = Vec::new();
        for (k, a) in objects.iter().enumerate() {
            for (l, b) in objects.iter().enumerate().skip(k + 1) {
                let closing = self.closing_speed(k, l) as f64;
                if closing <= 0.0 {
                    continue;
                }
                let mass = |o: &Object| (!o.is_static()).then(|| o.phyxels.total_mass());
                let mu = match (mass(a), mass(b)) {
                    (Some(ma), Some(mb)) => ma * mb / (ma + mb),
                    (Some(m), None) | (None, Some(m)) => m,
                    (None, None) => continue,
                };
                let radius = [(a, k), (b, l)]
                    .into_iter()
                    .filter(|(o, _)| !o.is_static())
                    .map(|(_, i)| thickness(i))
                    .fold(f64::INFINITY, f64::min);
                let thinnest = thickness(k).min(thickness(l));
                let spring = crate::contact::params::contact_params(a, b, 1.0).stiffness as f64;
                let depth = (3.0 * mu * closing * closing
                    / (4.0 * std::f64::consts::PI * radius * spring))
                    .cbrt();
                if depth > IMPACT_DEPTH_WARNING * thinnest {
                    out.push(format!(
                        "{} and {} approach at {} m/s: the penalty contact needs \
                         about {depth:.2e} m of penetration to stop them, more than \
                         {IMPACT_DEPTH_WARNING} of the thinner body's thickness 3V/A = \
                         {thinnest:.2e} m: they may pass through each other; raise \
                         contact_stiffness, thicken the body or lower the speed \
                         (docs/SCENES.md, \"Limits\")",
                        self.label(k),
                        self.label(l),
                        speed_text(closing)
                    ));
                }
            }
        }
        out
    }

    /// How fast objects k and l close along the line between their positions at the
    /// start (m/s; negative when they fly apart, static objects at rest).
    pub(super) fn closing_speed(&self, k: usize, l: usize) -> f32 {
        let (a, b) = (&self.objects[k], &self.objects[l]);
        let velocity = |o: &ObjectSpec| {
            if o.is_static {
                Vec3::ZERO
            } else {
                Vec3::from(o.velocity)
            }
        };
        let d = Vec3::from(b.position) - Vec3::from(a.position);
        -(velocity(b) - velocity(a)).dot(d.normalize_or_zero())
    }

    /// `objects[i] 'name'` (without the name if it has none), for messages.
    pub(super) fn label(&self, i: usize) -> String {
        match self.objects[i].name.as_str() {
            "" => format!("objects[{i}]"),
            name => format!("objects[{i}] '{name}'"),
        }
    }

    pub(super) fn fast_approaches(&self) -> Vec<String> {
        let mut out = Vec::new();
        for (k, a) in self.objects.iter().enumerate() {
            for (l, b) in self.objects.iter().enumerate().skip(k + 1) {
                let closing = self.closing_speed(k, l);
                let (slow, c) = [(a, k), (b, l)]
                    .into_iter()
                    .map(|(o, i)| (i, o.material.wave_speed()))
                    .fold((k, f32::INFINITY), |m, x| if x.1 < m.1 { x } else { m });
                if closing > c {
                    out.push(format!(
                        "{} and {} approach at {} m/s, faster than the P-wave speed \
                         {} m/s of {}: penalty contact may let them pass through each \
                         other; raise contact_stiffness or lower the speed (docs/SCENES.md, \
                         \"Limits\")",
                        self.label(k),
                        self.label(l),
                        speed_text(closing as f64),
                        speed_text(c as f64),
                        self.label(slow)
                    ));
                }
            }
        }
        out
    }
}

/// Stopping depth of an impact, as a fraction of the thinner body's thickness scale
/// `3V/A`, above which `Scene::build` warns (`Scene::deep_impacts`): penalty contact
/// pushes back only in proportion to depth, and a body pushed through more than its
/// thickness comes out on the other side. A 5 cm ball (E = 10 MPa) onto a 1 cm static
/// wall (3V/A = 1.45 cm), estimated depth against that thickness: at 20 m/s (0.62) and
/// 30 m/s (0.81) it bounces, at 50 m/s (1.14) and 100 m/s (1.81) it passes through
/// (`mls`).
pub const IMPACT_DEPTH_WARNING: f64 = 0.75;

/// Relative difference between a moving object's sampled volume (phyxel count × lattice
/// cell) and its shape's analytic volume above which `Scene::build` warns
/// ([`RunRecord::warnings`](crate::world::RunRecord::warnings)): mass is density × sampled volume, so a body a few phyxels
/// across gets too much or too little of it (a sphere sampled by 20 phyxels: +52%).
pub const MASS_WARNING: f64 = 0.25;

/// The warning for `obj` built from `spec` if its mass is off by more than
/// [`MASS_WARNING`] (moving objects of a shape with a volume only).
pub(super) fn mass_warning(spec: &ObjectSpec, obj: &Object) -> Option<String> {
    let analytic = moving_volume(spec)?;
    let p = &obj.phyxels;
    let sampled: f64 = p.volume[..p.len()].iter().map(|&v| v as f64).sum();
    let off = sampled / analytic - 1.0;
    (off.abs() > MASS_WARNING).then(|| {
        format!(
            "its {} phyxels hold {sampled:.3e} m³ of the shape's {analytic:.3e} m³ ({:+.0}%), \
             and its mass (density × sampled volume) is off as much: refine the spacing \
             (about four phyxels across the thinnest part; docs/SCENES.md, \"Limits\")",
            p.len(),
            100.0 * off
        )
    })
}

/// The analytic volume (m³) of a moving object whose shape has one (not a plane, not an
/// empty mesh): what the sampling warnings measure against.
pub(super) fn moving_volume(spec: &ObjectSpec) -> Option<f64> {
    let v = spec.shape.volume() as f64;
    (!spec.is_static && v > 0.0).then_some(v)
}

/// Largest mean surfel spacing `√(area / surfels)`, as a fraction of a moving body's
/// thickness scale `3 V / A` (its radius for a sphere), above which `Scene::build` warns
/// ([`RunRecord::warnings`](crate::world::RunRecord::warnings)): the implicit surface cannot follow a body sampled so coarsely,
/// and contacts are missed. Measured on `two-spheres` (r = 0.1 m, ±1 m/s): with 20
/// surfels per sphere (0.79 of the radius) they pass through each other; with 25 (0.71)
/// they bounce but sink 39% of the radius in; with 40 (0.56) 14%, with 60 (0.46) 9%,
/// and at the default sampling a few percent (docs/SCENES.md, "Limits").
pub const SURFACE_WARNING: f64 = 0.5;

/// The warning for `obj` built from `spec` if its surfels are too sparse for its
/// size ([`SURFACE_WARNING`]; moving objects of a shape with a volume only).
pub(super) fn surface_warning(spec: &ObjectSpec, obj: &Object) -> Option<String> {
    moving_volume(spec)?;
    let (thickness, area) = (thickness_scale(&spec.shape)?, spec.shape.area() as f64);
    let n = obj.surfels.len();
    let spacing = (area / n.max(1) as f64).sqrt();
    (spacing > SURFACE_WARNING * thickness).then(|| {
        format!(
            "its {n} surfels are {spacing:.3e} m apart on average, {:.2} of its thickness \
             scale 3V/A = {thickness:.3e} m (more than {SURFACE_WARNING}): contacts may be \
             missed or sink deep; refine the surfel spacing (docs/SCENES.md, \"Limits\")",
            spacing / thickness
        )
    })
}

/// Strain `ρ |g| H / E` under a body's own weight (H: its height along gravity) above
/// which the build warns that it may collapse. `sphere-on-plane` with the ball at
/// E = 3 kPa (0.67 by this H: the phyxels' height plus a spacing) holds, squashed to a
/// third of its height; at 2 kPa (1.01) and below it sinks through the plane on `mls`.
/// The `self-contact` ring, meant to buckle onto itself, is at 0.62; the other
/// built-in scenes stay below 0.1. Bodies stacked on it add their weight
/// (`load_above`: twice their mass counts as own weight).
pub const WEIGHT_WARNING: f32 = 0.8;

/// An object's phyxels seen along gravity: the box of their positions across it (two
/// axes) and their lowest point along it (the largest depth along `gravity`).
pub(super) struct Footprint {
    lo: [f32; 2],
    hi: [f32; 2],
    lowest: f32,
}

/// The [`Footprint`] of `o` under a non-zero `gravity`.
pub(super) fn footprint(o: &Object, gravity: Vec3) -> Footprint {
    let down = gravity.normalize();
    let (u, v) = down.any_orthonormal_pair();
    o.phyxels.pos.iter().fold(
        Footprint {
            lo: [f32::INFINITY; 2],
            hi: [f32::NEG_INFINITY; 2],
            lowest: f32::NEG_INFINITY,
        },
        |f, p| {
            let (a, b) = (p.dot(u), p.dot(v));
            Footprint {
                lo: [f.lo[0].min(a), f.lo[1].min(b)],
                hi: [f.hi[0].max(a), f.hi[1].max(b)],
                lowest: f.lowest.max(p.dot(down)),
            }
        },
    )
}

/// Mass (kg) that the other moving objects stack on `objects[k]` under `gravity`: those
/// whose lowest phyxel lies above its centre of mass and whose footprint (the box of
/// their phyxels across gravity) overlaps its own. They come to rest on it, or on a body
/// that rests on it, so their weight joins its own (0 without gravity). `footprints`
/// holds every object's [`footprint`].
pub(super) fn load_above(
    objects: &[Object],
    footprints: &[Footprint],
    k: usize,
    gravity: Vec3,
) -> f32 {
    let obj = &objects[k];
    if obj.is_static() || gravity == Vec3::ZERO {
        return 0.0;
    }
    let own = &footprints[k];
    let c = obj.phyxels.centre_of_mass();
    let centre = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32).dot(gravity.normalize());
    objects
        .iter()
        .zip(footprints)
        .enumerate()
        .filter(|&(j, (o, _))| j != k && !o.is_static())
        .filter(|(_, (_, f))| {
            // `lowest` is the largest depth along gravity: above the centre means less.
            f.lowest < centre && (0..2).all(|a| f.lo[a] <= own.hi[a] && f.hi[a] >= own.lo[a])
        })
        .map(|(_, (o, _))| o.phyxels.total_mass() as f32)
        .sum()
}

/// The warning for a moving `obj` resting on something (a static object or its own
/// fixed phyxels) under `gravity` if its own weight and the `load` (kg) of the bodies
/// stacked on it ([`load_above`]) strain it past [`WEIGHT_WARNING`]:
/// `ρ |g| H / E · (1 + 2 load / m)`. Its own weight's stress grows from 0 at its top to
/// `ρ |g| H` at its base (mean strain half of that), a load's `|g| load / A` is the same
/// all through it (`A = V / H`, its mean cross-section): a load strains it as much as
/// twice its mass of own weight. A 10 cm cube (1 kg) under a 10 kg cube (docs/SCENES.md,
/// "Limits"): at E = 20 kPa (1.08) it is squeezed out through the plane, at 30 kPa
/// (0.72) it holds but tips, at 50 kPa (0.43) it holds.
pub(super) fn weight_warning(
    obj: &Object,
    gravity: Vec3,
    supported: bool,
    load: f32,
) -> Option<String> {
    let g = gravity.length();
    if obj.is_static() || !supported || g == 0.0 {
        return None;
    }
    let down = gravity / g;
    let (lo, hi) = obj
        .phyxels
        .pos
        .iter()
        .map(|p| p.dot(down))
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), h| {
            (a.min(h), b.max(h))
        });
    let height = hi - lo + obj.phyxel_spacing;
    let m = &obj.material;
    let factor = 1.0 + 2.0 * load / obj.phyxels.total_mass() as f32;
    let strain = m.density * g * height * factor / m.young;
    let what = if load > 0.0 {
        format!(
            "its own weight and the {load:.3e} kg of the bodies stacked on it strain it by \
             about ρ|g|H/E · (1 + 2 · {load:.3e} kg / m) = {strain:.2}"
        )
    } else {
        format!("its own weight strains it by about ρ|g|H/E = {strain:.2}")
    };
    (strain > WEIGHT_WARNING).then(|| {
        format!(
            "{what} (H = {height:.3e} m along gravity, E = {:e} Pa): too soft to keep its \
             shape; it may collapse and sink through what holds it (young >= {:.3e} Pa \
             keeps it below {WEIGHT_WARNING})",
            m.young,
            m.density * g * height * factor / WEIGHT_WARNING
        )
    })
}

/// Share of an object's phyxels with a flat neighbourhood
/// ([`crate::dynamics::Diagnostics::flat_phyxels`]) above which the build warns. The
/// built-in scenes have none; a plate one phyxel layer thick has all of them, and on
/// `mls` (no stiffness across the layer) a ball dropped on one crumples it until it goes
/// NaN, at any dt.
pub const FLAT_WARNING: f64 = 0.01;

/// The warning for `obj` if many of its phyxels have flat neighbourhoods
/// ([`FLAT_WARNING`]; backends that fit no moment matrix report none).
pub(super) fn flat_warning(obj: &Object) -> Option<String> {
    let flat = obj
        .dynamics
        .diagnostics(&obj.phyxels, &obj.material)
        .flat_phyxels?;
    let n = obj.phyxels.len();
    (flat as f64 > FLAT_WARNING * n as f64).then(|| {
        format!(
            "{flat} of its {n} phyxels have neighbourhoods that do not span 3D (the body is \
             about one phyxel layer thick at this spacing): the {} backend has no stiffness \
             across them, so the body may crumple or blow up under load; refine the spacing \
             (at least two layers) or use sph",
            obj.dynamics.name()
        )
    })
}

/// The thickness scale `3V/A` of a shape (m): its radius for a sphere, half the side of a
/// cube, about 1.5 times a plate's thickness; `None` for shapes without a volume
/// (planes).
pub(super) fn thickness_scale(shape: &Shape) -> Option<f64> {
    let (volume, area) = (shape.volume() as f64, shape.area() as f64);
    (volume > 0.0 && area > 0.0).then(|| 3.0 * volume / area)
}

/// A speed (m/s) for messages: three decimals, in scientific notation from 10⁴ on (a
/// speed of 1e30 in plain notation has 31 digits).
pub(super) fn speed_text(v: f64) -> String {
    if v.abs() < 1e4 {
        format!("{v:.3}")
    } else {
        format!("{v:.3e}")
    }
}
