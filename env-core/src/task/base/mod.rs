//! What several tasks share, so that no task builds on another: the cube a task carries with
//! its observation slots, predicates and judgement ([`cube`]), and small helpers every task's
//! observation and info use (the info entry of a reward term, norms of observation slots,
//! orientations as observations carry them). Tasks use this module; it names no task.

pub(crate) mod cube;
pub mod objects;

use crate::error::Result;
use crate::task::config::RewardType;
use crate::task::observation::{info_field, InfoField, InfoType};
use crate::task::reward::{compute_batch_with, RewardTerm};

/// The reward context of the tasks whose dense reward reads its weighted `reach` and `grasp`
/// terms back from the step's info and computes the rest from the goals.
pub(crate) const REACH_GRASP_CONTEXT: [&str; 2] = ["reward_reach", "reward_grasp"];

/// `Task::compute_rewards` of such a task: `reward(achieved, desired, reach, grasp)` of each of
/// the `n` transitions (`goal_dim` entries per goal; contexts rows of
/// [`REACH_GRASP_CONTEXT`], needed with the dense reward) into `out`.
pub(crate) fn compute_reach_grasp_rewards(
    reward_type: RewardType,
    goal_dim: usize,
    (achieved, desired, contexts): (&[f32], &[f32], &[f32]),
    out: &mut [f32],
    reward: impl Fn(&[f32], &[f32], f32, f32) -> f32,
) -> Result<()> {
    compute_batch_with(
        achieved,
        desired,
        goal_dim,
        contexts,
        REACH_GRASP_CONTEXT.len(),
        reward_type == RewardType::Dense,
        out,
        |a, d, row| reward(a, d, row[0], row[1]),
    )
}

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
