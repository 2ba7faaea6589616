//! What several tasks share, so that no task builds on another: the cube a task carries with
//! its observation slots, predicates and judgement ([`cube`]), and small helpers every task's
//! observation and info use (the info entry of a reward term, norms of observation slots,
//! orientations as observations carry them). Tasks use this module; it names no task.

pub(crate) mod cube;
pub mod objects;

use crate::task::observation::{info_field, InfoField, InfoType};
use crate::task::reward::RewardTerm;

/// The info entry reporting a reward term, weighted.
pub(crate) const fn term_field(term: RewardTerm) -> InfoField {
    info_field(term.info_key, InfoType::Float, term.description)
}

/// The Euclidean norm of an observation slot, computed in f64 from its f32 values.
pub(crate) fn norm(v: &[f32]) -> f64 {
    v.iter()
        .map(|&x| (x as f64) * (x as f64))
        .sum::<f64>()
        .sqrt()
}

/// `q` as x, y, z, w with w >= 0, as observations carry orientations.
pub(crate) fn canonical(q: &nalgebra::UnitQuaternion<f64>) -> [f64; 4] {
    let c = if q.w < 0.0 { -q.coords } else { q.coords };
    [c.x, c.y, c.z, c.w]
}
