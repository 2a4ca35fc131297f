//! The contact springs of an implicit solve: each contact surfel's penalty spring,
//! dashpot and Coulomb friction (Keiser et al. 2004, eqs. 3–7), as forces on the
//! island's phyxels at trial velocities and as their linearisation.
//!
//! A pair in a solve takes its whole contact force from it (the pipeline spreads none
//! of it). Along the normal: the pipeline's force at the step's start plus its linear
//! change over the step (`−k dt v_n − c Δv_n`), clamped to push only — one Newton step
//! of the penalty force, the linearly implicit contact of Baraff and Witkin (1998).
//! Along the tangent: a stick anchor (Cundall and Strack 1979, [`crate::contact::stick`]): the
//! tangential spring `F_t = −k_t ξ`, `ξ = ξ₀ + dt v_t`, with `k_t` the normal spring's
//! stiffness and `ξ₀` carried from the last step, returned to Coulomb's cone
//! `|F_t| ≤ μ N` with the normal force of the same iterate. A sticking contact holds its
//! elongation, so it does not creep, and its tangent is the spring's `k_t dt²`, no
//! stiffer than the normal one's: CG sees nothing stiffer than a frictionless contact.
//!
//! A spring reads its contact surfel's velocity from, and spreads its force to, the
//! phyxels of each side as the pipeline's distribution does (`contact::distribute`:
//! normalised weights and the couple that makes the force act at the surfel). The
//! reading is the transpose of the spreading: the weighted mean velocity plus the
//! weights' best-fit rotation at the surfel, so the tangent stays symmetric.

use super::newton::Member;
use super::springs::{ContactSpring, ContactSprings, SpringSide};
use super::transfer::Transfer;
use glam::{Mat3, Vec3};

/// Newton iterations over which friction follows the iterates' normal force.
pub const FRICTION_UPDATES: u32 = 3;

/// Where a spring side's dofs lie in the island's vectors.
#[derive(Clone, Copy, Debug)]
pub(super) struct Side {
    pub offset: usize,
    pub member: usize,
    pub spring: SpringSide,
    /// The weights' centroid from the member's mean position (m; [`Transfer`]).
    pub centroid: Vec3,
}

/// A spring of the island and its state over the step's Newton iterations.
#[derive(Clone, Copy, Debug)]
pub(super) struct Active {
    /// Index into `ContactSprings::springs`.
    pub index: u32,
    pub a: Side,
    pub b: Option<Side>,
    /// Approach speed at `vₙ` (the dashpot's reference).
    pub approach0: f32,
    /// The normal force is above zero at the current iterate (the spring and the
    /// friction are in the tangent).
    pub pushing: bool,
    /// The normal force friction scales with (N; see [`Active::force`]).
    pub friction_normal: f32,
    /// Friction's tangent coefficient `−∂F_t/∂v_t` across the slip (N·s/m): `k_t dt`
    /// while sticking, `μ N dt / |ξ|` while sliding.
    pub drag: f32,
    /// Unit slip direction along which a sliding contact's friction does not change
    /// (the tangent leaves it out), or zero while sticking.
    pub slide: Vec3,
    /// The anchor's elongation at the last iterate (m), on the cone while sliding.
    pub stick: Vec3,
    /// Velocity of side b when it is no member of the island (static, or a tool's given
    /// motion: [`ContactSpring::given`]).
    pub given: Vec3,
    /// The force on side a at the last iterate (N): what a tool on side b receives,
    /// reversed.
    pub last_force: Vec3,
}

impl Active {
    pub fn new(index: u32, a: Side, b: Option<Side>, given: Vec3) -> Self {
        Self {
            index,
            a,
            b,
            approach0: 0.0,
            pushing: true,
            friction_normal: 0.0,
            drag: 0.0,
            slide: Vec3::ZERO,
            stick: Vec3::ZERO,
            given,
            last_force: Vec3::ZERO,
        }
    }

    /// Velocity of side a relative to side b at the contact surfel, for the island's
    /// velocities last loaded into `x` ([`Transfer::load`]).
    pub fn relative(&self, x: &Transfer, springs: &ContactSprings) -> Vec3 {
        let at = |s: &Side| x.read(springs, s);
        at(&self.a) - self.b.as_ref().map_or(self.given, at)
    }

    /// The change of [`Active::relative`] for a change of the island's velocities last
    /// loaded into `dx`: a side outside the island (static, a tool) does not change
    /// with them.
    pub fn relative_change(&self, dx: &Transfer, springs: &ContactSprings) -> Vec3 {
        let at = |s: &Side| dx.read(springs, s);
        at(&self.a) - self.b.as_ref().map_or(Vec3::ZERO, at)
    }

    /// The spring's force on side a at relative velocity `rel` (N), and the state of
    /// its linearisation there.
    ///
    /// Friction is the stick anchor's spring returned to the cone (see the module), and
    /// its tangent the exact derivative of that return: `k_t dt²` over the tangent
    /// plane while sticking, `μ N dt² / |ξ|` across the slip direction while sliding.
    ///
    /// Friction scales with the iterate's normal force over the first
    /// [`FRICTION_UPDATES`] Newton iterations, then with the last of those: the tangent
    /// leaves out how friction changes with the normal force (that term would not be
    /// symmetric), and a contact landing within the step, whose normal force changes
    /// most, then still converges.
    pub fn force(&mut self, sp: &ContactSpring, rel: Vec3, dt: f32, iteration: u32) -> Vec3 {
        let now = sp.normal.dot(rel);
        let change = -sp.stiffness * dt * now - sp.damping * (now - self.approach0);
        // Push only: the spring may take the force to zero, not pull.
        let total = sp.force + change;
        self.pushing = total > 0.0;
        let mut f = sp.normal * total.max(0.0);
        self.drag = 0.0;
        if iteration < FRICTION_UPDATES {
            self.friction_normal = total.max(0.0);
        }
        let normal = self.friction_normal;
        self.slide = Vec3::ZERO;
        self.stick = Vec3::ZERO;
        if sp.friction > 0.0 && self.pushing {
            let slip = rel - now * sp.normal;
            let trial = sp.stick + slip * dt;
            let (k, cap) = (sp.stiffness, sp.friction * normal);
            let len = trial.length();
            if k * len <= cap {
                f -= k * trial;
                self.drag = k * dt;
                self.stick = trial;
            } else {
                let dir = trial / len;
                f -= cap * dir;
                self.drag = cap * dt / len;
                self.slide = dir;
                self.stick = dir * (cap / k);
            }
        }
        self.last_force = f;
        f
    }

    /// The spring's row of the tangent applied to the relative motion `p` of side a
    /// against b: `(k dt² + c dt) n nᵀ p` while pushing, plus friction's
    /// `dt · drag · (P_t − s sᵀ) p` (`P_t`: the tangent plane, `s`: [`Active::slide`]).
    pub fn tangent(&self, sp: &ContactSpring, p: Vec3, dt: f32) -> Vec3 {
        if !self.pushing {
            return Vec3::ZERO;
        }
        let n = sp.normal;
        let along = n.dot(p);
        let plane = p - along * n;
        n * ((sp.stiffness * dt * dt + sp.damping * dt) * along)
            + (plane - self.slide * self.slide.dot(plane)) * (dt * self.drag)
    }
}

impl Active {
    /// The matrix [`Active::tangent`] applies, or `None` while the spring does not push.
    pub fn tangent_matrix(&self, sp: &ContactSpring, dt: f32) -> Option<Mat3> {
        if !self.pushing {
            return None;
        }
        let outer = |a: Vec3| Mat3::from_cols(a * a.x, a * a.y, a * a.z);
        let normal = outer(sp.normal);
        let plane = Mat3::IDENTITY - normal - outer(self.slide);
        Some(normal * (sp.stiffness * dt * dt + sp.damping * dt) + plane * (dt * self.drag))
    }
}

/// Adds a side's share of a spring's tangent `t` to the per-phyxel `blocks`, lumped:
/// phyxel j takes `wⱼ Gⱼᵀ t Gⱼ`, with `wⱼ Gⱼ = wⱼ (I + Cᵀ [rⱼ]ₓ)` its column of the
/// side's reading ([`ContactSprings::velocity`]). The weights sum to one, so by Jensen's
/// inequality the lumped blocks bound the side's rows `Σⱼₖ wⱼ wₖ Gⱼᵀ t Gₖ` from above,
/// and stay in the 3×3 diagonal blocks a body's factor already holds. Fixed phyxels
/// take nothing.
pub(super) fn lump(
    blocks: &mut [Mat3],
    springs: &ContactSprings,
    members: &[Member<'_>],
    transfer: &Transfer,
    s: &Side,
    t: Mat3,
) {
    let fixed = &members[s.member].phyxels.fixed;
    let ct = s.spring.couple.transpose();
    for &(j, w) in springs.weights_of(&s.spring) {
        if fixed[j as usize] != 0 {
            continue;
        }
        let i = s.offset + j as usize;
        let r = transfer.offset(i, s.centroid);
        let cross = Mat3::from_cols(
            Vec3::new(0.0, r.z, -r.y),
            Vec3::new(-r.z, 0.0, r.x),
            Vec3::new(r.y, -r.x, 0.0),
        );
        let g = Mat3::IDENTITY + ct * cross;
        blocks[i] += g.transpose() * t * g * w;
    }
}
