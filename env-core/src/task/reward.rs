//! Rewards and the success predicates, as pure functions of the goals and of the goal-free
//! quantities an environment reports in its info.
//!
//! - `sparse`: `-1` while the cube is farther than the success threshold from the goal, `0`
//!   within it (the convention hindsight experience replay expects).
//! - `dense`: a staged sum, each term in `[0, weight]`:
//!
//! | term | weight | value |
//! |---|---|---|
//! | `reach` | 1 | `1 - tanh(5 d)`, `d` = distance from the TCP to the cube centre |
//! | `grasp` | 1 | 1 while both fingers squeeze the cube (`is_grasped`) |
//! | `lift` | 1 | cube height above its floor resting height over the platform's height, clipped to [0, 1] |
//! | `carry` | 2 | `1 - tanh(5 d)`, `d` = distance from the cube to the goal |
//! | `place` | 5 | 1 once the cube is placed: released, at rest, on the platform, within the threshold |
//!
//! A placed cube earns more than one held at the goal (`1 + 0 + 1 + 2 + 5` against
//! `1 + 1 + 1 + 2`), so releasing it is worth learning. `reach`, `grasp` and `lift` do not
//! depend on the goal; `carry` and `place` are recomputed from `achieved_goal` and
//! `desired_goal`, so relabelled goals (HER) get exactly the reward the environment would
//! have given.

use crate::error::{Error, Result};
use crate::task::config::RewardType;
use crate::task::observation::GOAL_DIM;

/// Weight of the `reach` term.
pub const REACH_WEIGHT: f32 = 1.0;
/// Weight of the `grasp` term.
pub const GRASP_WEIGHT: f32 = 1.0;
/// Weight of the `lift` term.
pub const LIFT_WEIGHT: f32 = 1.0;
/// Weight of the `carry` term.
pub const CARRY_WEIGHT: f32 = 2.0;
/// Weight of the `place` term.
pub const PLACE_WEIGHT: f32 = 5.0;

/// The goal-free inputs of the reward, as reported in the step info.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RewardContext {
    /// The weighted `reach` term.
    pub reach: f32,
    /// The weighted `grasp` term.
    pub grasp: f32,
    /// The weighted `lift` term.
    pub lift: f32,
    /// No robot link touches the cube.
    pub cube_released: bool,
    /// The cube moves slower than the rest thresholds.
    pub cube_at_rest: bool,
    /// The cube touches the platform.
    pub cube_on_platform: bool,
}

/// The dense reward's terms, weighted; the reward is their sum in this order.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RewardTerms {
    /// See the module table.
    pub reach: f32,
    /// See the module table.
    pub grasp: f32,
    /// See the module table.
    pub lift: f32,
    /// See the module table.
    pub carry: f32,
    /// See the module table.
    pub place: f32,
}

impl RewardTerms {
    /// The dense reward: the terms summed in a fixed order.
    pub fn total(&self) -> f32 {
        self.reach + self.grasp + self.lift + self.carry + self.place
    }
}

/// The goal-dependent verdicts for one transition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GoalVerdict {
    /// Distance from the cube to the goal (m).
    pub distance: f64,
    /// Within the success threshold.
    pub is_success: bool,
    /// Within the threshold, released, at rest, on the platform.
    pub is_placed: bool,
    /// The reward.
    pub reward: f32,
    /// The dense terms (all zero for the sparse reward).
    pub terms: RewardTerms,
}

/// `1 - tanh(5 d)`: 1 at the target, 0.5 at 11 cm, fading to 0 beyond half a metre.
pub fn closeness(distance: f64) -> f32 {
    (1.0 - (5.0 * distance).tanh()) as f32
}

/// The reward function of an environment: its type and success threshold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RewardFunction {
    /// Sparse or dense.
    pub reward_type: RewardType,
    /// Success threshold (m).
    pub success_threshold: f64,
}

impl RewardFunction {
    /// Distance between two goal positions, computed in f64 from the f32 values the
    /// observation carries (so every caller gets the same bits).
    pub fn distance(achieved: &[f32], desired: &[f32]) -> f64 {
        achieved
            .iter()
            .zip(desired)
            .map(|(&a, &d)| {
                let diff = a as f64 - d as f64;
                diff * diff
            })
            .sum::<f64>()
            .sqrt()
    }

    /// Success, placement and reward of one transition.
    pub fn evaluate(
        &self,
        achieved: &[f32],
        desired: &[f32],
        context: &RewardContext,
    ) -> GoalVerdict {
        let distance = Self::distance(achieved, desired);
        let is_success = distance < self.success_threshold;
        let is_placed =
            is_success && context.cube_released && context.cube_at_rest && context.cube_on_platform;
        match self.reward_type {
            RewardType::Sparse => GoalVerdict {
                distance,
                is_success,
                is_placed,
                reward: if is_success { 0.0 } else { -1.0 },
                terms: RewardTerms::default(),
            },
            RewardType::Dense => {
                let terms = RewardTerms {
                    reach: context.reach,
                    grasp: context.grasp,
                    lift: context.lift,
                    carry: CARRY_WEIGHT * closeness(distance),
                    place: if is_placed { PLACE_WEIGHT } else { 0.0 },
                };
                GoalVerdict {
                    distance,
                    is_success,
                    is_placed,
                    reward: terms.total(),
                    terms,
                }
            }
        }
    }

    /// Batched reward for `n` transitions: `achieved` and `desired` hold `n x 3` positions,
    /// `contexts` one entry per transition (may be empty for the sparse reward, which does not
    /// read it). Writes `n` rewards into `out`.
    pub fn compute_batch(
        &self,
        achieved: &[f32],
        desired: &[f32],
        contexts: &[RewardContext],
        out: &mut [f32],
    ) -> Result<()> {
        if achieved.len() % GOAL_DIM != 0 {
            return Err(Error::WrongLength {
                what: "achieved_goal (n x 3)".into(),
                expected: (achieved.len() / GOAL_DIM + 1) * GOAL_DIM,
                got: achieved.len(),
            });
        }
        let n = achieved.len() / GOAL_DIM;
        crate::error::ensure_len("desired_goal (n x 3)", achieved.len(), desired.len())?;
        crate::error::ensure_len("reward output", n, out.len())?;
        let needs_context = self.reward_type == RewardType::Dense;
        if needs_context || !contexts.is_empty() {
            crate::error::ensure_len("info entries", n, contexts.len())?;
        }
        for (name, values) in [("achieved_goal", achieved), ("desired_goal", desired)] {
            if let Some((i, &v)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(Error::NonFinite {
                    what: format!("{name}[{}][{}]", i / GOAL_DIM, i % GOAL_DIM),
                    value: v as f64,
                });
            }
        }
        let empty = RewardContext::default();
        for (i, r) in out.iter_mut().enumerate() {
            let span = i * GOAL_DIM..(i + 1) * GOAL_DIM;
            let context = contexts.get(i).unwrap_or(&empty);
            *r = self
                .evaluate(&achieved[span.clone()], &desired[span], context)
                .reward;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn placed_context() -> RewardContext {
        RewardContext {
            reach: REACH_WEIGHT,
            grasp: 0.0,
            lift: LIFT_WEIGHT,
            cube_released: true,
            cube_at_rest: true,
            cube_on_platform: true,
        }
    }

    #[test]
    fn sparse_is_minus_one_outside_the_threshold_and_zero_inside() {
        let f = RewardFunction {
            reward_type: RewardType::Sparse,
            success_threshold: 0.05,
        };
        let goal = [0.5, 0.3, 0.125];
        let near = [0.5, 0.3 + 0.049, 0.125];
        let far = [0.5, 0.3 + 0.051, 0.125];
        let ctx = RewardContext::default();
        assert_eq!(f.evaluate(&near, &goal, &ctx).reward, 0.0);
        assert!(f.evaluate(&near, &goal, &ctx).is_success);
        assert_eq!(f.evaluate(&far, &goal, &ctx).reward, -1.0);
        assert!(!f.evaluate(&far, &goal, &ctx).is_success);
    }

    #[test]
    fn placing_beats_holding_at_the_goal() {
        let f = RewardFunction {
            reward_type: RewardType::Dense,
            success_threshold: 0.05,
        };
        let goal = [0.5, 0.3, 0.125];
        let holding = RewardContext {
            reach: REACH_WEIGHT,
            grasp: GRASP_WEIGHT,
            lift: LIFT_WEIGHT,
            cube_released: false,
            cube_at_rest: true,
            cube_on_platform: false,
        };
        let held = f.evaluate(&goal, &goal, &holding);
        let placed = f.evaluate(&goal, &goal, &placed_context());
        assert!(!held.is_placed && placed.is_placed);
        assert!(placed.reward > held.reward + 2.0, "{placed:?} vs {held:?}");
        assert_eq!(placed.reward, placed.terms.total());
        // Placed but outside the threshold is not placed.
        let off = [0.5, 0.36, 0.125];
        assert!(!f.evaluate(&off, &goal, &placed_context()).is_placed);
    }

    #[test]
    fn batch_matches_single_and_rejects_bad_shapes() {
        let f = RewardFunction {
            reward_type: RewardType::Dense,
            success_threshold: 0.05,
        };
        let achieved = [0.5, 0.3, 0.125, 0.1, 0.1, 0.025];
        let desired = [0.5, 0.31, 0.125, 0.5, 0.3, 0.125];
        let contexts = [placed_context(), RewardContext::default()];
        let mut out = [0.0; 2];
        f.compute_batch(&achieved, &desired, &contexts, &mut out)
            .unwrap();
        for i in 0..2 {
            let single = f.evaluate(
                &achieved[3 * i..3 * i + 3],
                &desired[3 * i..3 * i + 3],
                &contexts[i],
            );
            assert_eq!(out[i].to_bits(), single.reward.to_bits());
        }
        assert!(matches!(
            f.compute_batch(&achieved[..4], &desired[..4], &contexts, &mut out),
            Err(Error::WrongLength { .. })
        ));
        assert!(matches!(
            f.compute_batch(&achieved, &desired, &[], &mut out),
            Err(Error::WrongLength { .. })
        ));
        let nan = [f32::NAN, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert!(matches!(
            f.compute_batch(&nan, &desired, &contexts, &mut out),
            Err(Error::NonFinite { .. })
        ));
    }
}
