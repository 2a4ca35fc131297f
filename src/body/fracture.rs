//! Fracture into separate objects (Keiser et al. 2004, §4 and §8).
//!
//! The phyxels of an object that may break ([`crate::dynamics::Dynamics::can_fracture`]) form
//! a graph whose edges join phyxels closer than the influence radius `h_i` of either end
//! (a time-varying connectivity graph, Desbrun & Cani 1996), counted each step by the
//! object's [`crate::body::connectivity::Connectivity`]. When the graph falls into
//! several connected components, each becomes its own [`Object`]: its phyxels (every
//! column), the surfels nearest to them (each surfel to exactly one piece), the material,
//! and a fresh backend of the same name. Pieces start stress-free in their current shape
//! (rest ← current, for phyxels and surfels): a fresh backend has no plastic state, and
//! the old rest shape would make a plastically deformed piece spring back. Mass and
//! momentum are copied phyxel by phyxel, so they are kept exactly; then crack surfels
//! close the new boundary (the private `crack_surfels`).

pub use crate::body::connectivity::{Components, components};
use crate::body::object::Object;
use crate::body::self_collision::SelfCollision;
use crate::dynamics::Dynamics;
use crate::points::phyxels::Phyxels;
use crate::points::surfels::Surfels;
use crate::spatial::grid::Grid;
use glam::Vec3;
use rayon::prelude::*;

/// What one split did (for the run summary, tests and reports).
#[derive(Clone, Debug, PartialEq)]
pub struct SplitEvent {
    /// Step after which the object split (1-based, as `World::steps`).
    pub step: u64,
    /// Id of the object that broke.
    pub parent: u32,
    /// Ids of its pieces.
    pub pieces: Vec<u32>,
    /// Phyxels per piece.
    pub piece_phyxels: Vec<usize>,
    /// Total mass before and after (kg, f64 sums of the same f32 masses).
    pub mass_before: f64,
    pub mass_after: f64,
    /// Linear momentum before and after (kg·m/s).
    pub momentum_before: [f64; 3],
    pub momentum_after: [f64; 3],
    /// Surfels of the object, and of all pieces before crack surfels were added.
    pub surfels_before: usize,
    pub surfels_split: usize,
    /// Crack surfels added over all pieces.
    pub crack_surfels: usize,
}

/// Splits `object` along `comps` (which must have ≥ 2 components). Piece `c` gets id
/// `*next_id + c` and the backend [`Dynamics::fragment`] builds for it. Gives the object
/// back unchanged when the backend builds none for some piece (e.g. a user backend
/// that does not override `fragment`).
pub fn split(
    object: Object,
    comps: &Components,
    step: u64,
    next_id: &mut u32,
) -> Result<(Vec<Object>, SplitEvent), Box<Object>> {
    let p = &object.phyxels;
    let n = p.len();
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); comps.count];
    for i in 0..n {
        members[comps.label[i] as usize].push(i);
    }
    // Each piece's phyxels (rest = current) and backend, before anything is cut.
    let piece_phyxels: Vec<Phyxels> = members
        .iter()
        .map(|idx| {
            let mut phyxels = p.gather(idx);
            phyxels.rest = phyxels.pos.clone();
            phyxels
        })
        .collect();
    let backends: Option<Vec<Box<dyn Dynamics>>> = piece_phyxels
        .iter()
        .map(|ph| object.dynamics.fragment(ph, &object.material))
        .collect();
    let Some(backends) = backends else {
        return Err(Box::new(object));
    };
    // Each surfel goes to the piece of its nearest phyxel (current positions).
    let grid = Grid::build(p.pos.iter(), object.max_influence.max(1e-6));
    let piece_of = |x: glam::Vec3| {
        let mut knn = Vec::with_capacity(1);
        grid.k_nearest(x, 1, &mut knn);
        knn.first().map_or(0, |&(i, _)| comps.label[i])
    };
    let surfel_piece: Vec<u32> = (0..object.surfels.len())
        .into_par_iter()
        .map(|s| piece_of(object.surfels.pos.get(s)))
        .collect();
    // The output mesh, moved to this step's shape, cut the same way (vertex by nearest
    // phyxel).
    let mut object = object;
    object.follow_mesh();
    let mut meshes = object.mesh.as_ref().map(|mesh| {
        let piece: Vec<u32> = (0..mesh.vertices.len())
            .into_par_iter()
            .map(|v| piece_of(mesh.vertices.pos.get(v)))
            .collect();
        mesh.split(&piece, &piece_phyxels)
    });
    let p = &object.phyxels;
    let mut surfel_members: Vec<Vec<usize>> = vec![Vec::new(); comps.count];
    for (s, &c) in surfel_piece.iter().enumerate() {
        surfel_members[c as usize].push(s);
    }
    let parent_mass = p.total_mass();
    let mut event = SplitEvent {
        step,
        parent: object.id,
        pieces: Vec::new(),
        piece_phyxels: Vec::new(),
        mass_before: parent_mass,
        mass_after: 0.0,
        momentum_before: p.momentum(),
        momentum_after: [0.0; 3],
        surfels_before: object.surfels.len(),
        surfels_split: 0,
        crack_surfels: 0,
    };
    let mut pieces = Vec::with_capacity(comps.count);
    let pieces_in = members.iter().zip(piece_phyxels).zip(backends);
    for (c, ((idx, phyxels), dynamics)) in pieces_in.enumerate() {
        let mut surfels = object.surfels.gather(&surfel_members[c]);
        surfels.rest = surfels.pos.clone();
        surfels.rest_normal = surfels.normal.clone();
        event.surfels_split += surfels.len();
        let crack = crack_surfels(p, &comps.label, c as u32, idx, &surfels, &grid);
        event.crack_surfels += crack.len();
        let surfels = surfels.concat(&crack);
        let id = *next_id;
        *next_id += 1;
        let mass = phyxels.total_mass();
        let q = phyxels.momentum();
        event.mass_after += mass;
        (0..3).for_each(|k| event.momentum_after[k] += q[k]);
        event.pieces.push(id);
        event.piece_phyxels.push(idx.len());
        let self_collision = object
            .self_collision
            .as_ref()
            .map(|_| SelfCollision::new(&phyxels));
        let mut piece = Object::new(
            id,
            format!("{}.{c}", object.name),
            surfels,
            phyxels,
            object.material.clone(),
            dynamics,
        );
        // The load is a force on the whole body: each piece takes its share by mass.
        piece.load = object.load * (mass / parent_mass.max(f64::MIN_POSITIVE)) as f32;
        piece.load_ramp = object.load_ramp;
        piece.distribution_support = object.distribution_support;
        if object.graded {
            piece.set_contact_spacings(
                object.phyxel_spacing,
                object.surfel_spacing,
                object.contact_influence,
            );
        }
        piece.parent = Some(object.id);
        piece.self_collision = self_collision;
        piece.mesh = meshes.as_mut().and_then(|m| m[c].take());
        pieces.push(piece);
    }
    Ok((pieces, event))
}

/// `disk radius = spacing / √(π/2)`: the relation between surfel spacing and radius the
/// objects use (`Object::surfel_spacing`).
fn radius_for_spacing(spacing: f32) -> f32 {
    spacing / std::f32::consts::FRAC_PI_2.sqrt()
}

/// How far (in influence radii) a phyxel looks for phyxels of other pieces to find
/// out that it lies on the broken side: a split is found only once the pieces are more
/// than one influence radius apart.
pub const CRACK_REACH: f32 = 2.0;

/// Crack surfels of piece `c`: a phyxel of the piece with phyxels of other pieces within
/// [`CRACK_REACH`] influence radii (current positions) lies on the broken side. It gets a
/// surfel half a spacing out along the mean direction to them, facing them, unless a
/// surfel of the piece already lies within one spacing of that spot (the old surface
/// covers it) or another phyxel of the piece lies within ¾ spacing of it (the phyxel is
/// not in the outer layer). Disk radius from the phyxel spacing (crack surfels are as far
/// apart as phyxels).
fn crack_surfels(
    p: &Phyxels,
    label: &[u32],
    c: u32,
    idx: &[usize],
    piece_surfels: &Surfels,
    grid: &Grid,
) -> Surfels {
    let r_max = p.spacing[..p.len()].iter().fold(0.0f32, |a, &b| a.max(b));
    let have = Grid::build(piece_surfels.pos.iter(), r_max.max(1e-6));
    let new: Vec<(Vec3, Vec3, f32, Vec3)> = idx
        .par_iter()
        .filter_map(|&i| {
            let xi = p.pos.get(i);
            let mut away = Vec3::ZERO;
            grid.for_each_within(xi, CRACK_REACH * p.radius[i], |j, _| {
                if label[j] != c {
                    away += (p.pos.get(j) - xi).normalize_or_zero();
                }
            });
            let n = away.try_normalize()?;
            let r = p.spacing[i];
            let at = xi + 0.5 * r * n;
            let mut covered = false;
            have.for_each_within(at, r, |_, _| covered = true);
            grid.for_each_within(at, 0.75 * r, |j, _| {
                covered |= j != i && label[j] == c;
            });
            (!covered).then(|| (at, n, radius_for_spacing(r), p.vel.get(i)))
        })
        .collect();
    let pos: Vec<Vec3> = new.iter().map(|e| e.0).collect();
    let normal: Vec<Vec3> = new.iter().map(|e| e.1).collect();
    let radius: Vec<f32> = new.iter().map(|e| e.2).collect();
    let mut s = Surfels::at_rest(&pos, &normal, &radius);
    for (k, e) in new.iter().enumerate() {
        s.vel.set(k, e.3);
    }
    s
}

/// True when `object` is checked for fracture after each step.
pub fn may_fracture(object: &Object) -> bool {
    !object.is_static()
        && object.phyxels.len() > 1
        && object.dynamics.can_fracture(&object.material)
}
