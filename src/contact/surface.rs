//! The contact surface Φ (Keiser et al. 2004, §6): each colliding surfel moved along its
//! segment to where the two implicit surfaces, weighted by stiffness, balance.

use super::*;

/// One side of the segment field at a point: `f` and its normal.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Side {
    f: f32,
    normal: Vec3,
}

/// `f_a`, `f_b` along one colliding surfel's segment: the implicit surfaces where a
/// surfel kernel reaches, else the first-order extension `n·(x − p)` of the signed
/// distance from the segment's anchor point p on that surface. Deep inside an overlap the
/// truncated implicit surface is undefined anyway, and the extension saves a k-nearest
/// search per evaluation (docs/ARCHITECTURE.md).
pub(super) struct SegmentField<'a, 'b> {
    s: &'a PairSurfaces<'b>,
    anchor_a: (Vec3, Vec3),
    anchor_b: (Vec3, Vec3),
    /// The segment's start and its own surface's `sample_near` there (already taken
    /// for the anchor's normal); `from_a` says which surface that is.
    start: Vec3,
    start_own: Option<SurfaceSample>,
    from_a: bool,
    /// The colliding surfel, whose detection sampled the other surface at the start and
    /// at the projection.
    colliding: &'a Colliding,
    /// Each side's last kernel query, for Brent's next evaluation close by.
    kept_a: NearHits,
    kept_b: NearHits,
}

impl SegmentField<'_, '_> {
    fn side((p, n): (Vec3, Vec3), near: Option<SurfaceSample>, x: Vec3) -> Side {
        match near {
            Some(s) => Side {
                f: s.f,
                normal: s.normal,
            },
            None => Side {
                f: n.dot(x - p),
                normal: n,
            },
        }
    }

    /// `sample_near` of surface a (`on_a`) or b at `x`, reusing the start's and
    /// detection's samples and that side's last query.
    fn near(&mut self, on_a: bool, x: Vec3) -> Option<SurfaceSample> {
        let s = self.s;
        let (surface, kept) = if on_a {
            (&s.a, &mut self.kept_a)
        } else {
            (&s.b, &mut self.kept_b)
        };
        let own = on_a == self.from_a;
        match (own, x == self.start, x == self.colliding.projection) {
            (true, true, _) => self.start_own,
            (false, true, _) => self.colliding.near_surfel,
            (false, false, true) => self.colliding.near_projection,
            _ => surface.sample_near_kept(x, kept),
        }
    }

    fn f_a(&mut self, x: Vec3) -> Side {
        let near = self.near(true, x);
        Self::side(self.anchor_a, near, x)
    }

    fn f_b(&mut self, x: Vec3) -> Side {
        let near = self.near(false, x);
        Self::side(self.anchor_b, near, x)
    }
}

/// Most field evaluations remembered per segment (Brent's two brackets and 40 steps).
pub(super) const SEGMENT_EVALUATIONS: usize = 42;

/// Moves every colliding surfel onto Φ: the root of F on the segment from the surfel to
/// its projection onto the other surface, by Brent's method; surfels whose root leaves
/// the intersection volume are dropped (paper §6). The root's samples are taken from
/// Brent's evaluations, not recomputed.
pub fn contact_surface(
    det: &PairDetection,
    s: &PairSurfaces<'_>,
    p: &ContactParams,
    scratch: &mut PatchScratch,
    patch: &mut ContactPatch,
) {
    let tol = 0.05 * p.spacing;
    // `own` is the surface the colliding surfel lies on, `other` the one it is inside;
    // the anchors are the surfel and its projection, with their surfaces' normals.
    let place = |c: &Colliding, own: &Surfels, from_a: bool, object: usize| {
        let start = own.pos.get(c.surfel as usize);
        let own_surface = if from_a { &s.a } else { &s.b };
        let start_own = own_surface.sample_near(start);
        let own_normal = own_surface.sample_given(start, start_own)?.normal;
        let (anchor_a, anchor_b) = if from_a {
            ((start, own_normal), (c.projection, c.normal))
        } else {
            ((c.projection, c.normal), (start, own_normal))
        };
        let mut field = SegmentField {
            s,
            anchor_a,
            anchor_b,
            start,
            start_own,
            from_a,
            colliding: c,
            kept_a: NearHits::default(),
            kept_b: NearHits::default(),
        };
        let seg = c.projection - start;
        let len = seg.length();
        // The segment's end is the projection itself (not `start + seg`, which may round
        // off it), so detection's sample there is reused.
        let at = |t: f32| {
            if t == 1.0 {
                c.projection
            } else {
                start + t * seg
            }
        };
        let (x, a, b) = if len < 1e-4 * p.spacing {
            (start, field.f_a(start), field.f_b(start))
        } else {
            let mut seen = [(0.0f32, Side::default(), Side::default()); SEGMENT_EVALUATIONS];
            let mut n_seen = 0;
            let t = brent(
                |t| {
                    let x = at(t);
                    let (a, b) = (field.f_a(x), field.f_b(x));
                    if n_seen < SEGMENT_EVALUATIONS {
                        seen[n_seen] = (t, a, b);
                        n_seen += 1;
                    }
                    // `F(x) = λ_a f_a(x) − λ_b f_b(x)` (paper eq. 3).
                    Some(p.lambda_a * a.f - p.lambda_b * b.f)
                },
                0.0,
                1.0,
                1e-3 * p.spacing / len,
                40,
            )?;
            let x = at(t);
            match seen[..n_seen].iter().find(|e| e.0 == t) {
                Some(&(_, a, b)) => (x, a, b),
                None => (x, field.f_a(x), field.f_b(x)),
            }
        };
        if a.f > tol || b.f > tol {
            return None;
        }
        // The surfel's own velocity, and the other surface's nearest surfel's.
        let v_own = own.vel.get(c.surfel as usize);
        let (other_surfels, other_surface) = if from_a {
            (s.surfels_b, &s.b)
        } else {
            (s.surfels_a, &s.a)
        };
        let nearest = other_surface.nearest(c.projection).map(|(k, _)| k);
        let v_other = nearest.map_or(Vec3::ZERO, |k| other_surfels.vel.get(k));
        let own_radius = own.radius[c.surfel as usize];
        let other_radius = nearest.map_or(own_radius, |k| other_surfels.radius[k]);
        Some(ContactSurfel {
            pos: x,
            normal: (p.lambda_a * a.normal - p.lambda_b * b.normal).try_normalize()?,
            object,
            surfel: c.surfel,
            area: carrier_area(
                own_radius,
                own.rest_normal.get(c.surfel as usize),
                if from_a {
                    s.carrier_spacing_a
                } else {
                    s.carrier_spacing_b
                },
            ),
            force: Vec3::ZERO,
            anchor_a: if a.f <= 0.0 { anchor_a.0 } else { x },
            anchor_b: if b.f <= 0.0 { anchor_b.0 } else { x },
            velocity: if from_a {
                v_own - v_other
            } else {
                v_other - v_own
            },
            stick: Vec3::ZERO,
            scale: local_scale(own_radius, other_radius, p.spacing),
        })
    };
    let n_a = det.a_in_b.len();
    let placed = &mut scratch.placed;
    placed.clear();
    placed.resize(n_a + det.b_in_a.len(), None);
    placed.par_iter_mut().enumerate().for_each(|(k, slot)| {
        *slot = if k < n_a {
            let c = &det.a_in_b[k];
            s.carriers_a[c.surfel as usize]
                .then(|| place(c, s.surfels_a, true, det.a))
                .flatten()
        } else {
            let c = &det.b_in_a[k - n_a];
            s.carriers_b[c.surfel as usize]
                .then(|| place(c, s.surfels_b, false, det.b))
                .flatten()
        };
    });
    patch.a = det.a;
    patch.b = det.b;
    patch.surfels.clear();
    patch.surfels.extend(placed.iter().flatten());
    patch.render.clear();
    patch.not_carriers = det
        .a_in_b
        .iter()
        .filter(|c| !s.carriers_a[c.surfel as usize])
        .count()
        + det
            .b_in_a
            .iter()
            .filter(|c| !s.carriers_b[c.surfel as usize])
            .count();
    patch.dropped = placed.len() - patch.surfels.len() - patch.not_carriers;
}
