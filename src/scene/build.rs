//! Building a world from a scene: each object sampled and given its backend, the
//! overlap check, the warnings, and the time step.

use super::check::{phyxel_estimate, refined_estimate, sample_count, units_hint};
use super::warnings::{
    Footprint, flat_warning, footprint, load_above, mass_warning, surface_warning, weight_warning,
};
use super::*;
use crate::body::mesh::Surface;
use crate::body::output_mesh::OutputMesh;
use crate::body::shape::graded::{Grading, Refinement};
use crate::spatial::broad_phase::Aabb;

impl Scene {
    /// Samples every object and assembles the world. The scene is checked first
    /// ([`Scene::validate`]): its fields are public, and a scene changed in code must
    /// get the same errors as one read from a file, not a panic or a NaN world.
    pub fn build(&self, opts: &BuildOptions) -> Result<World, SceneError> {
        let origin = if self.name.is_empty() {
            "scene"
        } else {
            &self.name
        };
        self.validate(origin)?;
        check_overrides(opts, origin)?;
        let (objects, warnings) = self.build_objects(opts, origin)?;
        let mut world = World::new(objects, Vec3::from(self.gravity), 0.0);
        world.dt = self.choose_dt(&world, opts, origin)?;
        world.keep_stable = !opts.allow_unstable;
        world.preset = opts.preset.unwrap_or(self.preset);
        world.resampled_forces = self
            .resampled_forces
            .unwrap_or(world.preset == Preset::Paper);
        world.pairs_in_order = self.pairs_in_order.unwrap_or(world.preset == Preset::Paper);
        world.sleep = self.sleep.unwrap_or(true);
        world.record.warnings = warnings;
        if opts.dt.or(self.dt).is_none()
            && let Some(w) = contact_bound_warning(&world)
        {
            world.record.warnings.push(format!("{origin}: {w}"));
        }
        Ok(world)
    }

    /// Turns each `refine` zone `near` an object into a box in its object's coordinates:
    /// the named object's bounding box at the start (`placed`: shapes and placements),
    /// grown by `distance`, seen from the object's frame (the box of its corners).
    fn place_near_zones(
        &self,
        specs: &mut [(ObjectSpec, String)],
        placed: &[(Shape, (Quat, Vec3))],
        origin: &str,
    ) -> Result<(), SceneError> {
        let named = |j: usize| self.object_name(j);
        for k in 0..specs.len() {
            let (rot, pos) = placed[k].1;
            let half = placed[k].0.half_extents();
            for r in 0..specs[k].0.refine.len() {
                let zone = &mut specs[k].0.refine[r];
                let Some(near) = zone.near.take() else {
                    continue;
                };
                let distance = zone.distance.take().unwrap_or(0.0);
                let Some(j) = (0..placed.len()).find(|&j| j != k && named(j) == near) else {
                    continue; // `Scene::validate` names the mistake.
                };
                let (other, (other_rot, other_pos)) = &placed[j];
                let h = other.half_extents();
                let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
                for c in 0..8 {
                    let corner = Vec3::new(
                        if c & 1 == 0 { -h.x } else { h.x },
                        if c & 2 == 0 { -h.y } else { h.y },
                        if c & 4 == 0 { -h.z } else { h.z },
                    );
                    let local = rot.inverse() * (*other_rot * corner + *other_pos - pos);
                    lo = lo.min(local);
                    hi = hi.max(local);
                }
                let grow = Vec3::splat(distance);
                let (lo, hi) = (lo - grow, hi + grow);
                // Cells within the zone's band of it are refined too (`shape::graded`).
                let band = crate::body::shape::graded::GRADE * specs[k].0.spacing;
                let gap = (lo - half).max(-half - hi).max_element();
                if !(lo.is_finite() && hi.is_finite()) || gap > band {
                    return Err(SceneError(format!(
                        "{origin}: objects[{k}].refine[{r}]: near = {near:?} with distance \
                         {distance}: that object's box at the start ({lo} to {hi} in this \
                         object's coordinates) does not reach this object's (half extents \
                         {half}): nothing to refine; a larger distance reaches it"
                    )));
                }
                zone.min = Some(lo.to_array());
                zone.max = Some(hi.to_array());
            }
        }
        Ok(())
    }

    /// Samples each object with its backend (overrides applied), then checks that no two
    /// start overlapping; returns them with the build's warnings.
    fn build_objects(
        &self,
        opts: &BuildOptions,
        origin: &str,
    ) -> Result<(Vec<Object>, Vec<String>), SceneError> {
        let mut objects = Vec::with_capacity(self.objects.len());
        let mut placed = Vec::with_capacity(self.objects.len());
        let mut warnings = Vec::new();
        // A per-object warning as the build reports it.
        let tagged = |k: usize, obj: &Object, w: String| {
            format!("{origin}: objects[{k}] '{}': {w}", obj.name)
        };
        let gravity = Vec3::from(self.gravity);
        let grounded = self.objects.iter().any(|o| o.is_static);
        let preset = opts.preset.unwrap_or(self.preset);
        // Every object as it will be built, meshes loaded, before anything large is
        // allocated: the memory estimate needs them all.
        let mut specs = Vec::with_capacity(self.objects.len());
        for (k, spec) in self.objects.iter().enumerate() {
            let mut spec = spec.clone();
            // Loaded here once (a no-op if `Scene::load` did), for the overlap check too.
            spec.shape
                .load_mesh(Path::new(""))
                .map_err(|m| SceneError(format!("{origin}: objects[{k}].shape: {m}")))?;
            placed.push((spec.shape.clone(), spec.placement()));
            if !spec.is_static {
                spec.surfels = opts.surfels.or(spec.surfels);
                spec.phyxels = opts.phyxels.or(spec.phyxels);
            }
            if preset == Preset::Paper {
                spec.material.strain = crate::material::StrainForm::Paper;
                spec.influence = spec.influence.or(Some(PAPER_INFLUENCE));
            }
            let backend = match (&opts.backend, spec.is_static) {
                (_, true) => "static".to_string(),
                // A prescribed motion is no dynamics to swap.
                (Some(b), false) if spec.backend_name() != backends::KINEMATIC => b.clone(),
                (Some(_), false) => spec.backend_name().to_string(),
                (None, false) => spec.backend_name().to_string(),
            };
            specs.push((spec, backend));
        }
        self.place_near_zones(&mut specs, &placed, origin)?;
        check_memory(&specs, opts, origin)?;
        for (k, (spec, backend)) in specs.into_iter().enumerate() {
            let mut obj = spec
                .build(k as u32, &backend)
                .map_err(|m| SceneError(format!("{origin}: objects[{k}]: {m}")))?;
            if preset == Preset::Paper {
                obj.distribution_support = PAPER_DISTRIBUTION_SUPPORT;
            }
            if opts.meshes {
                obj.mesh = spec
                    .output_mesh(&obj.phyxels)
                    .map_err(|m| SceneError(format!("{origin}: objects[{k}]: {m}")))?;
            }
            // Only an override can get here with a plastic material on such a backend
            // (the scene's own `backend` is checked above): compared backends run it.
            let inelastic = (spec.material.is_plastic()
                && !spec.is_static
                && !backends::PLASTIC.contains(&backend.as_str()))
            .then(|| {
                format!(
                    "backend {backend} models no plastic flow: plastic_yield and \
                     plastic_creep are ignored, the body is elastic (plastic flow: {})",
                    backends::PLASTIC.join(", ")
                )
            });
            for w in [
                mass_warning(&spec, &obj),
                surface_warning(&spec, &obj),
                flat_warning(&obj),
                inelastic,
            ]
            .into_iter()
            .flatten()
            {
                warnings.push(tagged(k, &obj, w));
            }
            objects.push(obj);
        }
        // After every object is built: the weight check counts the bodies stacked above.
        // (None without gravity: nothing stacks, and `load_above` reads none.)
        let footprints: Vec<Footprint> = if gravity == Vec3::ZERO {
            Vec::new()
        } else {
            objects.iter().map(|o| footprint(o, gravity)).collect()
        };
        for (k, obj) in objects.iter().enumerate() {
            let supported = grounded || obj.phyxels.fixed.iter().any(|&f| f != 0);
            let load = load_above(&objects, &footprints, k, gravity);
            if let Some(w) = weight_warning(obj, gravity, supported, load) {
                warnings.push(tagged(k, obj, w));
            }
        }
        start_overlap(&objects, &placed).map_err(|m| SceneError(format!("{origin}: {m}")))?;
        warnings.extend(
            self.fast_approaches()
                .into_iter()
                .chain(self.deep_impacts(&objects))
                .map(|w| format!("{origin}: {w}")),
        );
        Ok((objects, warnings))
    }

    /// The time step: the scene's or the override, checked against the stable bound,
    /// else [`World::default_dt`].
    fn choose_dt(
        &self,
        world: &World,
        opts: &BuildOptions,
        origin: &str,
    ) -> Result<f32, SceneError> {
        let (stable, limiter_id) = world.stable_dt();
        let limiter_object = limiter_id.and_then(|id| world.object(id));
        let limiter = limiter_object.map(|o| o.name.clone()).unwrap_or_default();
        if stable.is_nan() || stable <= 0.0 {
            // Values each in range whose combination leaves f32's range: name them all.
            let what = limiter_object.map_or(String::new(), |o| {
                let m = &o.material;
                format!(
                    " (young = {:e} Pa, density = {:e} kg/m³, volume_stiffness = {:e} Pa, \
                     damping = {:e}, contact_stiffness = {:e}, phyxel spacing r_i = {:e} m)",
                    m.young,
                    m.density,
                    m.k_volume(),
                    m.damping,
                    m.contact_stiffness,
                    o.phyxel_spacing
                )
            });
            return Err(SceneError(format!(
                "{origin}: object '{limiter}' has no stable time step (bound {stable} s): its \
                 material and spacing{what} leave f32's range together; check them"
            )));
        }
        let dt = match opts.dt.or(self.dt) {
            Some(dt) => {
                if !(dt.is_finite() && dt > 0.0) {
                    return Err(SceneError(format!(
                        "{origin}: dt = {dt}: must be a finite number > 0"
                    )));
                }
                if dt > stable && !opts.allow_unstable {
                    // Full precision: rounded to a few digits, dt and the bound can print equal.
                    // The suggestion (the default dt) rounds to a value still below the bound.
                    let suggest = crate::world::DT_FRACTION * stable;
                    return Err(SceneError(format!(
                        "{origin}: dt = {dt} s exceeds the stable bound {stable} s of object '{limiter}' \
                         (explicit integration would blow up); use --dt {suggest:.3e} (90% of the bound, \
                         the default) or smaller, a coarser spacing or a softer material, or --allow-unstable"
                    )));
                }
                dt
            }
            None => world.default_dt(stable),
        };
        Ok(dt)
    }
}

/// The command line's overrides: sample counts within the limits, a known backend.
fn check_overrides(opts: &BuildOptions, origin: &str) -> Result<(), SceneError> {
    for (flag, name, n, limit) in [
        ("--surfels", "surfels", opts.surfels, MAX_SURFELS),
        ("--phyxel-count", "phyxels", opts.phyxels, MAX_PHYXELS),
    ] {
        if n == Some(0) {
            return Err(SceneError(format!(
                "{origin}: {flag} 0: an object needs at least one sample"
            )));
        }
        sample_count(name, n, limit).map_err(|m| SceneError(format!("{origin}: {flag}: {m}")))?;
    }
    if let Some(b) = opts.backend.as_deref()
        && !backends::NAMES.contains(&b)
    {
        return Err(SceneError(format!(
            "{origin}: backend override \"{b}\": unknown (available: {})",
            backends::NAMES.join(", ")
        )));
    }
    Ok(())
}

/// Refuses objects that start inside one another: a phyxel of one more than a phyxel
/// spacing (the coarser of the two objects') inside another's shape (`placed`: each
/// object's shape and placement). Contact handling pushes apart surfaces that overlap by
/// about a spacing (the built-in `pile` starts with 2 mm); interpenetrating bodies it
/// cannot untangle (deep surfels project onto the wrong side: pairs stay stuck or pass
/// through). A plane counts below its patch only (its `size`, widened by that spacing):
/// its contact acts where its surfels are, and a body beside the patch falls past it.
pub(super) fn start_overlap(
    objects: &[Object],
    placed: &[(Shape, (Quat, Vec3))],
) -> Result<(), String> {
    // Each object's phyxel box, and each shape's inverse rotation and bounding sphere:
    // a pair whose box misses the sphere's cube has no phyxel to test (testing every
    // phyxel against every shape takes 19 s for 5,000 separate spheres).
    let boxes: Vec<Aabb> = objects.iter().map(|o| Aabb::of(&o.phyxels.pos)).collect();
    let bounds: Vec<(Quat, f32)> = placed
        .iter()
        .map(|(shape, (rot, _))| (rot.inverse(), shape.half_extents().length()))
        .collect();
    for (i, a) in objects.iter().enumerate() {
        for (j, (shape, (_, centre))) in placed.iter().enumerate() {
            if i == j {
                continue;
            }
            let (inv, reach) = bounds[j];
            let plane = match shape {
                Shape::Plane { size } => Some(*size),
                _ => None,
            };
            let cube = (*centre - Vec3::splat(reach), *centre + Vec3::splat(reach));
            let apart = boxes[i].min.cmpgt(cube.1).any() || boxes[i].max.cmplt(cube.0).any();
            if plane.is_none() && apart {
                continue;
            }
            let slack = a.phyxel_spacing.max(objects[j].phyxel_spacing);
            let (mut inside, mut deepest) = (0usize, 0.0f32);
            for p in a.phyxels.pos.iter() {
                let local = inv * (p - *centre);
                // Beyond the bounding sphere nothing is inside; a plane's sdf is the
                // infinite plane's, so it is bounded by its patch (any depth below it).
                let outside = match plane {
                    Some([x, z]) => {
                        local.x.abs() > 0.5 * x + slack || local.z.abs() > 0.5 * z + slack
                    }
                    None => local.length() > reach,
                };
                if outside {
                    continue;
                }
                let d = shape.sdf(local);
                if d < -slack {
                    inside += 1;
                    deepest = deepest.max(-d);
                }
            }
            if inside > 0 {
                let b = &objects[j];
                return Err(format!(
                    "objects[{i}] ('{}') starts inside objects[{j}] ('{}'): {inside} of its \
                     phyxels lie more than a phyxel spacing r_i (their mean neighbour distance, {slack} m) within it, up to {deepest:.3e} m \
                     deep; place them apart (contact resolves touching surfaces, not bodies \
                     inside one another)",
                    a.name, b.name
                ));
            }
        }
    }
    Ok(())
}

/// The lattice spacing whose phyxel count is closest to `target`: starts from
/// `(volume/target)^(1/3)` (widened for thin shapes) and corrects a few times by the
/// cube root of the count ratio, since a small lattice's count jumps with the rounding
/// at the boundary. Never samples a lattice past the limits (it then returns the best
/// spacing so far, which `ObjectSpec::spacings` and the build check).
pub(super) fn lattice_spacing_for(shape: &Shape, target: u32) -> f32 {
    let target = target as f32;
    let mut s = (shape.volume() / target).cbrt();
    // A shape thinner than that spacing (a needle, a thin ring) gets far more phyxels
    // than its volume says: widen the first guess until the estimate is within a factor
    // the boundary layer of a compact body stays under (a sphere of 20 phyxels: 3), so
    // the search never samples a lattice of billions.
    for _ in 0..64 {
        if !(s.is_finite() && s > 0.0) || phyxel_estimate(shape, s) <= 8.0 * target as f64 {
            break;
        }
        s *= 1.25;
    }
    let mut best = (f32::INFINITY, s);
    for _ in 0..8 {
        let affordable = phyxel_estimate(shape, s) <= 2.0 * MAX_PHYXELS as f64
            && shape.lattice_points(s) <= MAX_LATTICE_POINTS
            && shape.inside_test_work(s) <= MAX_INSIDE_TEST_WORK;
        if !(s.is_finite() && s > 0.0 && affordable) {
            break;
        }
        let n = shape.sample_volume(s).positions.len() as f32;
        let err = (n / target - 1.0).abs();
        if err < best.0 {
            best = (err, s);
        }
        if err < 0.01 {
            break;
        }
        s *= (n / target).cbrt();
    }
    best.1
}

impl ObjectSpec {
    /// The rigid placement: local → world.
    pub fn placement(&self) -> (Quat, Vec3) {
        let r = self.rotation.map(f32::to_radians);
        (
            Quat::from_euler(EulerRot::XYZ, r[0], r[1], r[2]),
            Vec3::from(self.position),
        )
    }

    /// Phyxel and surfel spacing (m): given, or from the target counts `phyxels` and
    /// `surfels` and the shape's volume and area.
    pub fn spacings(&self, shape: &Shape) -> Result<(f32, f32), String> {
        let spacing = match self.phyxels {
            Some(n) => lattice_spacing_for(shape, n),
            None => self.spacing,
        };
        let surfel = match (self.surfels, self.surfel_spacing) {
            (Some(n), _) => (shape.area() / n as f32).sqrt(),
            (None, Some(s)) => s,
            (None, None) => 0.5 * spacing,
        };
        if let Some(n) = self
            .phyxels
            .filter(|_| !(spacing.is_finite() && spacing > 0.0))
        {
            return Err(format!(
                "phyxels = {n}: the shape has no volume to divide (give `spacing` instead)"
            ));
        }
        if let Some(n) = self
            .surfels
            .filter(|_| !(surfel.is_finite() && surfel > 0.0))
        {
            return Err(format!(
                "surfels = {n}: the shape has no area to divide (give `surfel_spacing` instead)"
            ));
        }
        // Counts a given spacing leads to (the lattice's boundary layer included), so that
        // a spacing orders of magnitude too small is refused before sampling exhausts
        // memory. (Target counts are checked against the limits as they are.)
        let t = surfel as f64;
        let estimates = [
            (
                self.phyxels.is_none(),
                "spacing",
                spacing,
                phyxel_estimate(shape, spacing),
                MAX_PHYXELS,
                "phyxels",
            ),
            (
                self.surfels.is_none(),
                "surfel_spacing",
                surfel,
                shape.area() as f64 / t.powi(2),
                MAX_SURFELS,
                "surfels",
            ),
        ];
        for (given, key, value, n, limit, what) in estimates {
            if given && n > limit as f64 {
                let key = match key {
                    "surfel_spacing" if self.surfel_spacing.is_none() => "spacing / 2",
                    k => k,
                };
                return Err(format!(
                    "{key} = {value}: gives about {n:.2e} {what}, more than the limit of \
                     {limit} per object (a coarser spacing, or a count: `{what} = N`){}",
                    units_hint(shape)
                ));
            }
        }
        let scan = shape.lattice_points(spacing);
        let work = shape.inside_test_work(spacing);
        if work > MAX_INSIDE_TEST_WORK {
            let key = self.spacing_key(spacing);
            return Err(format!(
                "{key}: sampling the mesh's volume tests {scan:.2e} lattice points against \
                 its {:.0} elements, {work:.2e} winding-number terms, more than the limit \
                 of {MAX_INSIDE_TEST_WORK:e} (about half a minute): a coarser spacing, or a \
                 mesh with fewer triangles",
                work / scan
            ));
        }
        if scan > MAX_LATTICE_POINTS {
            let key = self.spacing_key(spacing);
            return Err(format!(
                "{key}: the shape's bounding box holds {scan:.2e} lattice points to test, more \
                 than the limit of {MAX_LATTICE_POINTS:e} (the shape is thin for its extent): \
                 a coarser spacing"
            ));
        }
        Ok((spacing, surfel))
    }

    /// The graded sampling of the `refine` zones at the base `spacing` (m), or `None`
    /// for a uniform lattice. `Err` for a zone not finer than the spacing (which a
    /// `phyxels = N` count sets only now).
    pub(super) fn grading(&self, spacing: f32) -> Result<Option<Grading>, String> {
        if self.refine.is_empty() {
            return Ok(None);
        }
        let mut zones = Vec::with_capacity(self.refine.len());
        for (k, r) in self.refine.iter().enumerate() {
            let Some(zone) = r.zone() else {
                return Err(format!(
                    "refine[{k}]: give a box (`min`, `max`) or a sphere (`centre`, `radius`)"
                ));
            };
            if r.spacing >= spacing || r.spacing.is_nan() {
                let key = self.spacing_key(spacing);
                return Err(format!(
                    "refine[{k}].spacing = {}: not finer than the object's ({key})",
                    r.spacing
                ));
            }
            zones.push(Refinement {
                zone,
                spacing: r.spacing,
            });
        }
        Ok(Some(Grading {
            base: spacing,
            zones,
        }))
    }

    /// What set the phyxel spacing, for errors: the count asked for, or the spacing.
    pub(super) fn spacing_key(&self, spacing: f32) -> String {
        match self.phyxels {
            Some(n) => format!("phyxels = {n} (spacing {spacing} m)"),
            None => format!("spacing = {spacing}"),
        }
    }

    /// The backend this object asks for: `backend`, else [`DEFAULT_BACKEND`].
    pub fn backend_name(&self) -> &str {
        self.backend.as_deref().unwrap_or(DEFAULT_BACKEND)
    }

    /// The object's output mesh for mesh frames: its shape's triangles
    /// ([`Shape::triangulate`], edges of `MESH_EDGE` surfel spacings), or a point-cloud
    /// shape's own points and normals, placed as the object is and bound to the rest
    /// positions of its `phyxels`.
    pub fn output_mesh(&self, phyxels: &Phyxels) -> Result<Option<OutputMesh>, String> {
        let (rot, pos) = self.placement();
        let mut shape = self.shape.clone();
        shape.load_mesh(Path::new(""))?;
        let (_, surfel_spacing) = self.spacings(&shape)?;
        if let Shape::Mesh { mesh: Some(m), .. } = &shape
            && let Surface::Points(cloud) = m.as_ref()
        {
            let p: Vec<Vec3> = cloud.points.iter().map(|&p| rot * p + pos).collect();
            let n: Vec<Vec3> = cloud.normals.iter().map(|&n| rot * n).collect();
            return Ok(Some(OutputMesh::points(&p, &n, phyxels)));
        }
        Ok(shape.triangulate(MESH_EDGE * surfel_spacing).map(|(v, t)| {
            let v: Vec<Vec3> = v.iter().map(|&p| rot * p + pos).collect();
            OutputMesh::new(&v, t, phyxels)
        }))
    }

    /// Samples the shape and creates the object with backend `backend`.
    pub fn build(&self, id: u32, backend: &str) -> Result<Object, String> {
        let (rot, pos) = self.placement();
        // A mesh not loaded by `Scene::load`: its path is relative to the working directory.
        let mut shape = self.shape.clone();
        shape.load_mesh(Path::new(""))?;
        let (spacing, surfel_spacing) = self.spacings(&shape)?;
        // Nodal integration wants volumes fitted to the solid's moments; the particle
        // backends' lattice models do not (`Shape::sample_volume_nodal`).
        let nodal = [
            crate::backends::mls::NAME,
            crate::backends::mls::implicit::NAME,
        ];
        let grading = self.grading(spacing)?;
        if let Some(g) = &grading {
            graded_surfel_work(&shape, surfel_spacing, g)?;
        }
        if grading.is_some() && !self.is_static && !backends::GRADED.contains(&backend) {
            return Err(format!(
                "refine: backend {backend} (from --backend) models a uniform lattice: \
                 graded sampling needs {} or {}",
                crate::backends::mls::NAME,
                crate::backends::mls::implicit::NAME
            ));
        }
        let (vol, phyxel_levels) = match &grading {
            Some(g) => shape.sample_volume_graded(g),
            None if nodal.contains(&backend) => (shape.sample_volume_nodal(spacing), Vec::new()),
            None => (shape.sample_volume(spacing), Vec::new()),
        };
        // The estimates bound the sampling's cost; the count itself is known only now.
        if vol.positions.len() > MAX_PHYXELS {
            let key = self.spacing_key(spacing);
            return Err(format!(
                "{key}: gives {} phyxels, more than the limit of {MAX_PHYXELS} per object \
                 (a coarser spacing, or a smaller count: `phyxels = N`)",
                vol.positions.len()
            ));
        }
        // Each phyxel's mass is its volume times the density: both in range can still
        // overflow or underflow f32 together.
        for &v in &vol.volumes {
            let mass = v * self.material.density;
            if !(mass.is_finite() && mass > 0.0) {
                return Err(format!(
                    "material.density = {:e} kg/m³ at spacing = {spacing} m gives a phyxel a \
                     mass of {mass:e} kg ({v:e} m³ × density), outside f32's range: change \
                     the density or the spacing",
                    self.material.density
                ));
            }
        }
        let (surf, surfel_levels) = match &grading {
            Some(g) => shape.sample_surface_graded(surfel_spacing, g),
            None => (shape.sample_surface(surfel_spacing), Vec::new()),
        };
        self_overlap(&shape, &surf.positions, &surf.normals, surfel_spacing)?;
        let points: Vec<Vec3> = vol.positions.iter().map(|&p| rot * p + pos).collect();
        let mut phyxels = Phyxels::at_rest(&points, vol.cell_volume, self.material.density)
            .with_volumes(&vol.volumes, self.material.density);
        if let Some(f) = self.influence {
            for (h, r) in phyxels.radius.iter_mut().zip(&phyxels.spacing) {
                *h = f * r;
            }
        }
        let v = Vec3::from(self.velocity);
        let mut anchored = vec![0usize; self.fixed.len()];
        for (i, local) in vol.positions.iter().enumerate() {
            let inside = |r: &Region| (0..3).all(|c| local[c] >= r.min[c] && local[c] <= r.max[c]);
            for (count, r) in anchored.iter_mut().zip(&self.fixed) {
                *count += inside(r) as usize;
            }
            if self.fixed.iter().any(inside) {
                phyxels.fixed[i] = 1;
            } else if !self.is_static {
                phyxels.vel.set(i, v);
            }
        }
        // A box that anchors nothing leaves the body free: a mistake, not a setting.
        if let Some(r) = anchored.iter().position(|&n| n == 0) {
            let b = &self.fixed[r];
            return Err(format!(
                "fixed[{r}]: the box min = {:?}, max = {:?} holds no phyxel at spacing {spacing} \
                 (object-local coordinates, before rotation): widen it or refine the spacing",
                b.min, b.max
            ));
        }
        // A body anchored whole never moves: its velocity and load would be ignored.
        if phyxels.fixed[..phyxels.len()].iter().all(|&f| f != 0) {
            for (key, v) in [("velocity", self.velocity), ("load", self.load)] {
                if v != [0.0; 3] {
                    return Err(format!(
                        "{key} = {v:?}: has no effect: the `fixed` boxes anchor every phyxel \
                         of the body (for a body that never moves, use `static = true`)"
                    ));
                }
            }
        }
        let s_pos: Vec<Vec3> = surf.positions.iter().map(|&p| rot * p + pos).collect();
        let s_nrm: Vec<Vec3> = surf.normals.iter().map(|&n| rot * n).collect();
        // Stored in Morton order of cells a few surfels wide: neighbours sit together in
        // memory, whatever order the sampler emitted them in.
        let order = morton::order(&s_pos, SURFEL_ORDER_CELL * surfel_spacing);
        let mut surfels = Surfels::at_rest(&s_pos, &s_nrm, &surf.radii).gather(&order);
        if !self.is_static {
            for s in 0..surfels.len() {
                surfels.vel.set(s, v);
            }
        }
        let dynamics = backends::create(backend, &phyxels, &self.material)?;
        let name = if self.name.is_empty() {
            format!("object{id}")
        } else {
            self.name.clone()
        };
        let mut object = Object::new(id, name, surfels, phyxels, self.material.clone(), dynamics);
        if let Some(g) = &grading {
            let finest = g.finest_level();
            let phyxel_fine: Vec<bool> = phyxel_levels.iter().map(|&l| l == finest).collect();
            let surfel_fine: Vec<bool> =
                order.iter().map(|&k| surfel_levels[k] == finest).collect();
            if phyxel_fine.contains(&true)
                && (surfel_fine.contains(&true) || surfel_fine.is_empty())
            {
                object.use_finest_level(&phyxel_fine, &surfel_fine);
            } else {
                return Err(format!(
                    "refine: no phyxel or no surfel of the body lies in its finest zone (at \
                     spacing {} m): the zones refine only the inside of the shape's bounding box \
                     near them; move a zone onto the body",
                    spacing / (1u32 << finest) as f32
                ));
            }
        }
        object.load = Vec3::from(self.load);
        object.load_ramp = self.load_ramp;
        if self.self_collision && !self.is_static {
            object.self_collision = Some(SelfCollision::new(&object.phyxels));
        }
        Ok(object)
    }
}

/// Refuses a grading whose surfel sampling would exceed [`MAX_SURFELS`]: each level's
/// surfels are drawn over the whole surface at that level's spacing, then cut to the
/// level's leaves (`Shape::sample_surface_graded`), so the finest level costs the whole
/// surface at its spacing, however small its zone.
fn graded_surfel_work(shape: &Shape, surfel_spacing: f32, grading: &Grading) -> Result<(), String> {
    let finest = surfel_spacing as f64 / (1u64 << grading.finest_level()) as f64;
    let drawn = shape.area() as f64 / (finest * finest);
    if drawn > MAX_SURFELS as f64 {
        return Err(format!(
            "refine: the finest zone's surfels ({finest:.3e} m apart) are drawn over the \
             whole surface before the zone is cut out: about {drawn:.2e}, more than the \
             limit of {MAX_SURFELS}; a coarser zone `spacing` or `surfel_spacing`"
        ));
    }
    Ok(())
}

/// Edge length of the primitives' output meshes, in surfel spacings: a sphere's mesh
/// then has about 0.4 vertices per surfel, and writing mesh frames beside the surfel
/// frames adds under a tenth to a run that writes frames (`two-spheres`, every 10 steps).
pub const MESH_EDGE: f32 = 2.0;

/// How far below the moving bodies' own stable step the contact springs' bound may set
/// the default dt before the build warns, naming the stiffest `contact_stiffness`.
pub const CONTACT_BOUND_WARNING: f32 = 1e-3;

/// A default dt set by the contact springs far below the bodies' own stable step
/// (`contact_stiffness = 1e30` gives dt = 9.4e-18 s): it names the
/// stiffest object's `contact_stiffness` and the cost.
fn contact_bound_warning(world: &World) -> Option<String> {
    let own = world
        .objects
        .iter()
        .filter(|o| !o.is_static())
        .map(|o| o.dynamics.stable_dt(&o.phyxels, &o.material))
        .fold(f32::INFINITY, f32::min);
    // Against the dt the bodies alone would get (capped at a millisecond).
    if !(own.is_finite() && world.dt < CONTACT_BOUND_WARNING * world.default_dt(own)) {
        return None;
    }
    let stiffest = world.objects.iter().max_by(|a, b| {
        a.material
            .contact_stiffness
            .total_cmp(&b.material.contact_stiffness)
    })?;
    Some(format!(
        "dt = {:.2e} s is set by the contact springs (contact_stiffness = {:e} of '{}'), \
         {:.1e} times below the step the bodies alone would take ({:.2e} s): every \
         simulated second costs that many more steps; the default contact_stiffness of 4 \
         holds impacts up to about the P-wave speed, 16 somewhat faster (docs/SCENES.md, \
         \"Limits\")",
        world.dt,
        stiffest.material.contact_stiffness,
        stiffest.name,
        world.default_dt(own) / world.dt,
        world.default_dt(own)
    ))
}

/// Refuses a scene whose estimated memory ([`memory`]) exceeds the budget:
/// `opts.max_memory`, else a share of the memory the system has available (no check
/// where it does not say). The message gives the estimate, its largest object, the
/// budget and the knob.
fn check_memory(
    specs: &[(ObjectSpec, String)],
    opts: &BuildOptions,
    origin: &str,
) -> Result<(), SceneError> {
    let Some((budget, source)) = opts
        .max_memory
        .map(|b| (b, "--max-memory".to_string()))
        .or_else(memory::default_budget)
    else {
        return Ok(());
    };
    let mut total = 0.0;
    let mut largest = (0.0, 0);
    for (k, (spec, backend)) in specs.iter().enumerate() {
        // From the keys alone: `ObjectSpec::spacings` would search the lattice spacing
        // of a `phyxels = N` object by sampling, which the build does anyway. (A
        // spacing the checks refuse comes out infinite or NaN, or past a limit, and is
        // left to them.)
        let shape = &spec.shape;
        let (spacing, phyxels) = match spec.phyxels {
            Some(n) => ((shape.volume() as f64 / n as f64).cbrt(), n as f64),
            None => (
                spec.spacing as f64,
                phyxel_estimate(shape, spec.spacing)
                    + refined_estimate(shape, spec.spacing, &spec.refine),
            ),
        };
        let surfels = match (spec.surfels, spec.surfel_spacing) {
            (Some(n), _) => n as f64,
            (None, Some(s)) => shape.area() as f64 / (s as f64).powi(2),
            (None, None) => shape.area() as f64 / (0.5 * spacing).powi(2),
        };
        // Past a per-object limit the object's own check says so, naming its key.
        if phyxels > MAX_PHYXELS as f64 || surfels > MAX_SURFELS as f64 {
            continue;
        }
        let influence = spec
            .influence
            .unwrap_or(crate::points::phyxels::SUPPORT_FACTOR);
        let bytes = memory::object_bytes(phyxels, surfels, backend, influence);
        if bytes.is_finite() {
            total += bytes;
            if bytes > largest.0 {
                largest = (bytes, k);
            }
        }
    }
    if total <= budget as f64 {
        return Ok(());
    }
    let (bytes, k) = largest;
    Err(SceneError(format!(
        "{origin}: the scene needs about {} of memory, more than the budget of {} ({source}); \
         the largest of its {} objects, objects[{k}]{}, about {}. Coarser spacings or \
         fewer objects make it smaller; `--max-memory SIZE` (`BuildOptions::max_memory`) \
         sets the budget",
        memory::human(total),
        memory::human(budget as f64),
        specs.len(),
        match specs[k].0.name.as_str() {
            "" => String::new(),
            name => format!(" '{name}'"),
        },
        memory::human(bytes),
    )))
}

/// Share of a mesh's surface samples that may lie inside its own solid (tested a
/// quarter of a surfel spacing out along their normal) before it is refused as
/// overlapping itself. A closed, consistently oriented surface that does not intersect
/// itself has none (the built-in tests' meshes: 0); two cubes overlapping in one file
/// have 11.5%.
pub const SELF_OVERLAP_SHARE: f64 = 0.01;
/// Winding-number terms the self-overlap test may spend (about half a second on two
/// cores); past it, fewer samples are tested.
pub const SELF_OVERLAP_WORK: f64 = 3e7;

/// Refuses a triangle mesh that overlaps itself (part of its surface inside its own
/// solid, as where two parts of one file intersect): its surfels there would be inside
/// the body, and the solid's inside test counts the overlap twice. Not repaired: the
/// union of the parts is the user's to make, and says which surface is meant.
fn self_overlap(
    shape: &Shape,
    points: &[Vec3],
    normals: &[Vec3],
    spacing: f32,
) -> Result<(), String> {
    let Shape::Mesh {
        path,
        mesh: Some(m),
        ..
    } = shape
    else {
        return Ok(());
    };
    let crate::body::mesh::Surface::Triangles(t) = m.as_ref() else {
        return Ok(());
    };
    let (buried, tested) = t.buried_samples(points, normals, 0.25 * spacing, SELF_OVERLAP_WORK);
    if (buried as f64) <= SELF_OVERLAP_SHARE * tested as f64 {
        return Ok(());
    }
    Err(format!(
        "shape: the mesh '{path}' overlaps itself: {:.1}% of its surface ({buried} of \
         {tested} samples) lies inside its own solid, as where two parts of one file \
         intersect. Join the parts into one closed surface (a boolean union) before \
         loading, or load each part as its own object",
        100.0 * buried as f64 / tested.max(1) as f64
    ))
}
