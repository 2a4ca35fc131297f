//! Even, hole-free resampling of Φ for the render surface (Witkin–Heckbert, as in the
//! paper's §6).

use super::*;

/// Even, hole-free sampling of Φ for the render surface (after Witkin–Heckbert, as in
/// the paper's §6): deletion of surfels closer than half the spacing, insertion where a
/// tangent neighbourhood is empty, one relaxation pass with reprojection onto Φ, and
/// normals by PCA of the local neighbourhood (smallest eigenvector).
///
/// By default the forces stay on the unresampled contact surfels: which surfels deletion
/// and insertion keep changes discontinuously from step to step, and forces on them
/// would make a resting contact jitter, while a colliding surfel enters and leaves the
/// contact with zero penetration, so forces on those are continuous in time. With
/// `World::resampled_forces` (the paper's order) the forces act on the resampled
/// surfels instead, anchored by [`anchor`].
pub fn resample(patch: &mut ContactPatch, s: &PairSurfaces<'_>, p: &ContactParams) {
    patch.render.clear();
    if patch.surfels.is_empty() {
        return;
    }
    let h = p.spacing;
    let mut render = patch.surfels.clone();
    thin(&mut render, 0.5 * h);
    fill_holes(&mut render, patch.a, s, p);
    relax(&mut render, s, p);
    pca_normals(&mut render, 2.0 * h);
    patch.render = render;
}

/// Anchors each resampled contact surfel on the two original surfaces, as
/// `contact_surface` does for the colliding ones, so that forces can act on it: `d₁`
/// runs from it along Φ's normal n to surface a (where `f_a` crosses 0 going along +n:
/// a's surface faces b), `d₂` along −n to surface b; a side it is outside of gets no
/// overlap. Where the search fails (an overlap deeper than the kernel reaches, where
/// `f` is undefined), that side's overlap along n is the nearest placed contact
/// surfel's (`placed`: from the colliding surfels, whose segments reach any depth). Its
/// velocity is that of a's surfel nearest the first anchor relative to b's nearest the
/// second.
pub fn anchor(
    surfels: &mut [ContactSurfel],
    placed: &[ContactSurfel],
    s: &PairSurfaces<'_>,
    p: &ContactParams,
) {
    let h = p.spacing;
    let placed_grid = grid_of(placed, h);
    // The anchor on `surface` along `dir`: `x` itself where x is outside it (no
    // overlap on that side), `None` where the search fails.
    let along = |surface: &SurfaceField<'_>, x: Vec3, dir: Vec3| -> Option<Vec3> {
        let f = |t: f32| surface.sample(x + t * dir).map(|q| q.f);
        if f(0.0)? > 0.0 {
            return Some(x);
        }
        // The farthest end of the search that the kernel still reaches and lies outside.
        let hi = [4.0 * h, 2.0 * h, h, 0.5 * h]
            .into_iter()
            .find(|&t| f(t).is_some_and(|v| v > 0.0))?;
        let t = brent(f, 0.0, hi, 1e-3 * h, 40)?;
        Some(x + t * dir)
    };
    surfels.par_iter_mut().for_each(|c| {
        let (x, n) = (c.pos, c.normal);
        let (a, b) = (along(&s.a, x, n), along(&s.b, x, -n));
        let near = (a.is_none() || b.is_none())
            .then(|| placed_grid.nearest(x).map(|(k, _)| &placed[k]))
            .flatten();
        // The nearest placed surfel's overlap on one side, measured along n.
        let copied = |anchor: fn(&ContactSurfel) -> Vec3| {
            near.map_or(x, |q| x + (anchor(q) - q.pos).dot(n) * n)
        };
        c.anchor_a = a.unwrap_or_else(|| copied(|q| q.anchor_a));
        c.anchor_b = b.unwrap_or_else(|| copied(|q| q.anchor_b));
        let vel = |surface: &SurfaceField<'_>, surfels: &Surfels, at: Vec3| {
            surface
                .nearest(at)
                .map_or(Vec3::ZERO, |(k, _)| surfels.vel.get(k))
        };
        c.velocity = vel(&s.a, s.surfels_a, c.anchor_a) - vel(&s.b, s.surfels_b, c.anchor_b);
    });
}

pub(super) fn grid_of(surfels: &[ContactSurfel], cell: f32) -> Grid {
    Grid::build(surfels.iter().map(|c| c.pos), cell)
}

/// Deletes surfels with an earlier kept surfel within `r` (deterministic Poisson-disk).
pub(super) fn thin(surfels: &mut Vec<ContactSurfel>, r: f32) {
    let grid = grid_of(surfels, r);
    let mut keep = vec![true; surfels.len()];
    for i in 0..surfels.len() {
        let mut crowded = false;
        grid.for_each_within(surfels[i].pos, r, |j, _| crowded |= j < i && keep[j]);
        keep[i] = !crowded;
    }
    let mut k = 0;
    surfels.retain(|_| {
        k += 1;
        keep[k - 1]
    });
}

/// Inserts a surfel on Φ where one of six tangent directions of an existing surfel
/// has no surfel within 0.6 spacing, if that point lies in the intersection volume.
pub(super) fn fill_holes(
    surfels: &mut Vec<ContactSurfel>,
    object: usize,
    s: &PairSurfaces<'_>,
    p: &ContactParams,
) {
    let h = p.spacing;
    let grid = grid_of(surfels, h);
    let mut added: Vec<ContactSurfel> = Vec::new();
    for c in surfels.iter() {
        let t1 = c.normal.any_orthonormal_vector();
        let t2 = c.normal.cross(t1);
        for k in 0..6 {
            let ang = k as f32 * std::f32::consts::FRAC_PI_3;
            let guess = c.pos + h * (ang.cos() * t1 + ang.sin() * t2);
            let mut empty = true;
            grid.for_each_within(guess, 0.6 * h, |_, _| empty = false);
            if !empty || added.iter().any(|a| a.pos.distance(guess) < 0.6 * h) {
                continue;
            }
            if let Some(x) = reproject(guess, c.normal, s, p)
                && s.in_volume(x, 0.05 * h)
                && let Some(n) = s.normal(x, p)
            {
                added.push(ContactSurfel {
                    pos: x,
                    normal: n,
                    object,
                    surfel: NO_SURFEL,
                    area: 0.0,
                    force: Vec3::ZERO,
                    anchor_a: x,
                    anchor_b: x,
                    velocity: Vec3::ZERO,
                    stick: Vec3::ZERO,
                    scale: c.scale,
                });
            }
        }
    }
    surfels.extend(added);
}

/// The root of F along `x + t n`, |t| ≤ one spacing.
pub(super) fn reproject(x: Vec3, n: Vec3, s: &PairSurfaces<'_>, p: &ContactParams) -> Option<Vec3> {
    let h = p.spacing;
    let t = brent(|t| s.contact_function(p, x + t * n), -h, h, 1e-3 * h, 40)?;
    Some(x + t * n)
}

/// One relaxation pass: tangential repulsion from neighbours closer than the spacing,
/// then reprojection onto Φ (kept in place where reprojection fails).
pub(super) fn relax(surfels: &mut [ContactSurfel], s: &PairSurfaces<'_>, p: &ContactParams) {
    let h = p.spacing;
    let grid = grid_of(surfels, h);
    let moved: Vec<Vec3> = surfels
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let mut push = Vec3::ZERO;
            grid.for_each_within(c.pos, h, |j, d2| {
                if j != i {
                    let d = c.pos - surfels[j].pos;
                    let r = d2.sqrt().max(1e-9);
                    push += d / r * (h - r);
                }
            });
            let tangential = push - push.dot(c.normal) * c.normal;
            let guess = c.pos + 0.25 * tangential;
            match reproject(guess, c.normal, s, p) {
                Some(x) if s.in_volume(x, 0.05 * h) => x,
                _ => c.pos,
            }
        })
        .collect();
    for (c, x) in surfels.iter_mut().zip(moved) {
        c.pos = x;
    }
}

/// Normals by PCA of the neighbourhood within `r`, oriented like the current normal.
pub(super) fn pca_normals(surfels: &mut [ContactSurfel], r: f32) {
    let grid = grid_of(surfels, r);
    let normals: Vec<Vec3> = surfels
        .par_iter()
        .map(|c| {
            let (mut sum, mut n) = (Vec3::ZERO, 0);
            let mut pts = Vec::new();
            grid.for_each_within(c.pos, r, |j, _| {
                sum += surfels[j].pos;
                n += 1;
                pts.push(surfels[j].pos);
            });
            if n < 3 {
                return c.normal;
            }
            let mean = sum / n as f32;
            let mut cov = DMat3::ZERO;
            for q in pts {
                let d = (q - mean).as_dvec3();
                cov += DMat3::from_cols(d * d.x, d * d.y, d * d.z);
            }
            let (vals, vecs) = sym_eigen(cov);
            let k = (0..3)
                .min_by(|&x, &y| vals[x].total_cmp(&vals[y]))
                .unwrap_or(0);
            let e = vecs.col(k).as_vec3();
            // A flat, well-spread neighbourhood defines the plane; otherwise keep Φ's normal.
            if vals[k] > 0.1 * vals[(k + 1) % 3].min(vals[(k + 2) % 3]) {
                return c.normal;
            }
            if e.dot(c.normal) < 0.0 { -e } else { e }
        })
        .collect();
    for (c, n) in surfels.iter_mut().zip(normals) {
        c.normal = n;
    }
}
