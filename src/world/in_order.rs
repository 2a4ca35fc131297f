//! Pairs handled in order (Keiser et al. 2004, §8, the `animate` loop): once a pair's
//! contact surface Φ is built and resampled, each of its two objects' surfaces becomes
//! `S ∖ C ∪ Φ` for the pairs after it in the same step, so a later contact sees the
//! surface the earlier one left ("contact handling depends on the order of the object
//! pairs"). The next step starts again from the original surfels. `World::pairs_in_order`
//! (`preset = "paper"`) selects it; otherwise the pairs are independent and run in
//! parallel, which the paper finds makes "only little difference" (docs/ACCURACY.md,
//! "The paper's configuration", measures it).

use super::World;
use super::cache::SurfaceView;
use crate::body::object::Object;
use crate::contact::detect::{Candidates, DetectScratch, PairDetection, Volume, colliding_surfels};
use crate::contact::field::{SurfaceField, grid_cell, radius_range};
use crate::contact::{self, ContactPatch, ContactSurfel, PairSurfaces};
use crate::points::surfels::Surfels;
use crate::spatial::grid::Grid;
use glam::Vec3;

/// An object's surface as the earlier pairs of this step left it.
#[derive(Debug)]
struct Working {
    surfels: Surfels,
    /// Which of `surfels` carry contact forces: the kept carriers and every Φ surfel.
    carriers: Vec<bool>,
    grid: Grid,
}

impl Working {
    fn surface(&self) -> SurfaceField<'_> {
        let s = &self.surfels;
        SurfaceField::new(&s.pos, &s.normal, &s.radius[..s.len()], &self.grid)
    }
}

/// The buffers of [`contact_in_order`], kept between steps.
#[derive(Debug, Default)]
pub(super) struct InOrderScratch {
    /// Per object, its surface after the pairs handled so far (`None`: unchanged).
    working: Vec<Option<Working>>,
    detect: [DetectScratch; 2],
    detection: PairDetection,
}

/// The contact surfaces of every pair, handled one after another in pair order, each
/// against the surfaces the pairs before it left (module docs): detection again for a
/// pair with a changed side, then Φ, its resampling and, with
/// `World::resampled_forces`, the resampled surfels as the force carriers. Fills
/// `w.contact.patches` (the forces phase computes their forces); `w.contact.detections` keep the
/// detection against the original surfaces, which the render surface and the reported
/// depth use. Returns the contact surfels placed.
pub(super) fn contact_in_order(w: &mut World) -> u64 {
    let n = w.objects.len();
    let (dt, render, on_resampled) = (w.dt, w.render_contacts, w.resampled_forces);
    let cache = &mut w.cache;
    let scratch = &mut cache.in_order;
    scratch.working.clear();
    scratch.working.resize_with(n, || None);
    let view = SurfaceView::new(&w.objects, &cache.grids);
    let mut used = 0;
    for (d0, pair) in w.contact.detections.iter().zip(&w.contact.pairs) {
        let (a, b) = (d0.a, d0.b);
        let (wa, wb) = (scratch.working[a].as_ref(), scratch.working[b].as_ref());
        let (surfels_a, carriers_a) = columns(&w.objects[a], wa);
        let (surfels_b, carriers_b) = columns(&w.objects[b], wb);
        let s = PairSurfaces {
            a: wa.map_or_else(|| view.surface(a), Working::surface),
            b: wb.map_or_else(|| view.surface(b), Working::surface),
            surfels_a,
            surfels_b,
            carriers_a,
            carriers_b,
            carrier_spacing_a: w.objects[a].carrier_spacing,
            carrier_spacing_b: w.objects[b].carrier_spacing,
        };
        let d = if wa.is_none() && wb.is_none() {
            d0
        } else {
            let volume = |k: usize| Volume {
                phyxels: cache.grids.phyxel[k]
                    .as_ref()
                    .expect("grid built for pairs"),
                reach: w.objects[k].phyxel_spacing,
            };
            let side = |surfels, carriers| Candidates {
                surfels,
                blocks: None,
                only: (!render).then_some(carriers),
                margin: 0.0,
            };
            let det = &mut scratch.detection;
            let [sa, sb] = &mut scratch.detect;
            det.a = a;
            det.b = b;
            det.candidates = colliding_surfels(
                side(s.surfels_a, s.carriers_a),
                &s.b,
                &volume(b),
                pair,
                sa,
                &mut det.a_in_b,
                &mut det.a_near_b,
            ) + colliding_surfels(
                side(s.surfels_b, s.carriers_b),
                &s.a,
                &volume(a),
                pair,
                sb,
                &mut det.b_in_a,
                &mut det.b_near_a,
            );
            &scratch.detection
        };
        if d.a_in_b.is_empty() && d.b_in_a.is_empty() {
            continue;
        }
        if w.contact.patches.len() == used {
            w.contact.patches.push(ContactPatch::default());
        }
        if cache.patch.len() == used {
            cache.patch.push(Default::default());
        }
        let patch = &mut w.contact.patches[used];
        used += 1;
        let p = view.params(a, b, dt);
        contact::contact_surface(d, &s, &p, &mut cache.patch[used - 1], patch);
        contact::resample(patch, &s, &p);
        if on_resampled {
            contact::anchor(&mut patch.render, &patch.surfels, &s, &p);
            patch.surfels.clone_from(&patch.render);
        }
        let phi = if patch.render.is_empty() {
            &patch.surfels
        } else {
            &patch.render
        };
        let na = replaced(&s, true, &d.a_in_b, phi, w.objects[a].surfel_spacing);
        let nb = replaced(&s, false, &d.b_in_a, phi, w.objects[b].surfel_spacing);
        scratch.working[a] = Some(na);
        scratch.working[b] = Some(nb);
    }
    w.contact.patches.truncate(used);
    w.contact
        .patches
        .iter()
        .map(|p| p.surfels.len() as u64)
        .sum()
}

/// An object's surfels and force-carrier flags: as the earlier pairs left them when
/// `wk` is set, else its own.
fn columns<'a>(o: &'a Object, wk: Option<&'a Working>) -> (&'a Surfels, &'a [bool]) {
    match wk {
        Some(wk) => (&wk.surfels, &wk.carriers),
        None => (&o.surfels, &o.force_carrier),
    }
}

/// Side a's (`of_a`) or b's surface of the pair `s` with its colliding surfels
/// `colliding` replaced by the contact surface `phi`: `S ∖ C ∪ Φ`. The Φ surfels face
/// out of the object (Φ's normal points from a into b), have the disk radius of the
/// object's surfel spacing, the velocity of the object's nearest surfel, and carry
/// forces.
fn replaced(
    s: &PairSurfaces<'_>,
    of_a: bool,
    colliding: &[contact::detect::Colliding],
    phi: &[ContactSurfel],
    spacing: f32,
) -> Working {
    let (own, surface, carriers) = if of_a {
        (s.surfels_a, &s.a, s.carriers_a)
    } else {
        (s.surfels_b, &s.b, s.carriers_b)
    };
    let mut gone = vec![false; own.len()];
    for c in colliding {
        gone[c.surfel as usize] = true;
    }
    let kept: Vec<usize> = (0..own.len()).filter(|&i| !gone[i]).collect();
    let sign = if of_a { 1.0 } else { -1.0 };
    let points: Vec<Vec3> = phi.iter().map(|c| c.pos).collect();
    let normals: Vec<Vec3> = phi.iter().map(|c| sign * c.normal).collect();
    let radius = spacing * std::f32::consts::FRAC_2_PI.sqrt();
    let mut added = Surfels::at_rest(&points, &normals, &vec![radius; phi.len()]);
    for (i, &x) in points.iter().enumerate() {
        if let Some((k, _)) = surface.nearest(x) {
            added.vel.set(i, own.vel.get(k));
        }
    }
    let surfels = own.gather(&kept).concat(&added);
    let mut flags: Vec<bool> = kept.iter().map(|&i| carriers[i]).collect();
    flags.resize(surfels.len(), true);
    let (_, r_max) = radius_range(&surfels.radius[..surfels.len()]);
    let grid = Grid::build(surfels.pos.iter().take(surfels.len()), grid_cell(r_max));
    Working {
        surfels,
        carriers: flags,
        grid,
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::{BuildOptions, Scene};

    /// After a step of `two-spheres` at contact, each sphere's working surface is its
    /// surfels minus the colliding ones plus Φ: the count adds up, the kept surfels are
    /// the original ones in order, and the Φ surfels face out of their sphere (Φ's
    /// normal points from a into b, so b's copies are flipped). Reference: `S ∖ C ∪ Φ`
    /// (paper §8) and the spheres' geometry.
    #[test]
    fn the_working_surface_is_the_surfels_without_c_with_phi() {
        let mut scene = Scene::builtin("two-spheres").unwrap();
        scene.pairs_in_order = Some(true);
        scene.resampled_forces = Some(true);
        let mut w = scene.build(&BuildOptions::default()).unwrap();
        while w.contact.patches.is_empty() || w.contact.patches[0].render.len() < 20 {
            w.step();
            assert!(w.steps < 500, "no contact");
        }
        let d = &w.contact.detections[0];
        let phi = &w.contact.patches[0].render;
        for (k, colliding, sign) in [(0, &d.a_in_b, 1.0f32), (1, &d.b_in_a, -1.0)] {
            let o = &w.objects[k];
            let wk = w.cache.in_order.working[k]
                .as_ref()
                .expect("changed by the pair");
            let kept = o.surfels.len() - colliding.len();
            assert_eq!(wk.surfels.len(), kept + phi.len(), "object {k}");
            assert_eq!(wk.carriers.len(), wk.surfels.len());
            let mut gone = vec![false; o.surfels.len()];
            colliding
                .iter()
                .for_each(|c| gone[c.surfel as usize] = true);
            let originals = (0..o.surfels.len()).filter(|&i| !gone[i]);
            for (j, i) in originals.enumerate() {
                assert_eq!(wk.surfels.pos.get(j), o.surfels.pos.get(i));
                assert_eq!(wk.carriers[j], o.force_carrier[i]);
            }
            let centre = glam::Vec3::from_array(o.phyxels.centre_of_mass().map(|c| c as f32));
            for (j, c) in phi.iter().enumerate() {
                let n = wk.surfels.normal.get(kept + j);
                assert_eq!(n, sign * c.normal);
                assert!(n.dot(c.pos - centre) > 0.0);
                assert!(wk.carriers[kept + j]);
            }
        }
    }
}
