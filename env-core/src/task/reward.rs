//! Rewards and the success predicates, as pure functions of the goals and of the goal-free
//! quantities an environment reports in its info. Each task declares its dense reward's terms
//! ([`RewardTerm`], with their default weights) and the info keys its reward reads back
//! (`reward_context_keys`) in its [`TaskDescriptor`](crate::task::TaskDescriptor); the
//! configuration's `reward_weights` overrides the weights of the task's terms by name.
//!
//! The cube tasks share the staged reward below ([`RewardFunction`], each task using the terms
//! it declares; a term the task does not declare weighs 0):
//!
//! - `sparse`: `-1` while the cube is farther than the success threshold from the goal, `0`
//!   within it (the convention hindsight experience replay expects).
//! - `dense`: a staged sum, each term in `[0, weight]`, the weights options
//!   (`reward_weights` in the environment's configuration, as Gymnasium's MuJoCo v5
//!   environments take theirs):
//!
//! | term | default weight | value |
//! |---|---|---|
//! | `reach` | 1 | `1 - tanh(5 d)`, `d` = distance from the TCP to the cube centre |
//! | `grasp` | 1 | 1 while both fingers squeeze the cube (`is_grasped`) |
//! | `lift` | 1 | cube height above its floor resting height over the platform's height, clipped to [0, 1] |
//! | `carry` | 2 | `1 - tanh(5 d)`, `d` = distance from the cube to the goal |
//! | `place` | 5 | 1 once the cube is placed: released, at rest, on the platform, within the threshold |
//! | `release` | 0 | the gripper opening the action commands (0 closed, 1 fully open) while the cube is within the threshold |
//!
//! A placed cube earns more than one held at the goal (`1 + 0 + 1 + 2 + 5` against
//! `1 + 1 + 1 + 2`), so releasing it is worth learning. Finding it is another matter: the
//! fingers let go of the cube only when the gripper command is above about +0.5 for two
//! steps, which a policy that has learned to squeeze the cube through the whole carry almost
//! never samples (`docs/training.md`). `release`, off by default, pays for opening the hand
//! once the cube is at the goal, in proportion to the command, so the step towards letting go
//! is rewarded before the cube is placed (shaping that depends on the action, like the control
//! costs of the MuJoCo environments). It does not ask for the cube to touch the platform: a
//! learned grasp may hold it a centimetre above its resting height, from where it drops into
//! place. It is meant for goals on the platform; with air goals (`goal_air_probability`)
//! letting go loses `carry`. `reach`, `grasp`, `lift` and the gripper
//! opening do not depend on the goal; `carry`, `place` and `release` are recomputed from
//! `achieved_goal` and `desired_goal`, so relabelled goals (HER) get exactly the reward the
//! environment would have given.
//!
//! Over 600 lines: the staged cube reward, its terms and weights, the batched form every task
//! uses for `compute_reward`, and tests of each term's weighting, kept in one place.

use std::collections::BTreeMap;

use crate::error::{Error, Result};
use crate::task::config::RewardType;

/// Size of each goal this reward compares: a position.
pub const GOAL_DIM: usize = 3;

/// One term of a task's dense reward.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RewardTerm {
    /// Its name in `reward_weights`.
    pub name: &'static str,
    /// The info key that reports it, weighted (`reward_<name>`).
    pub info_key: &'static str,
    /// Its weight unless `reward_weights` sets one.
    pub default_weight: f64,
    /// What it pays for.
    pub description: &'static str,
}

/// The staged cube reward's terms ([`RewardFunction`], the module table), each with its
/// default weight. A cube task lists the ones it pays in its descriptor.
pub mod cube_terms {
    use super::RewardTerm;

    /// `reach`: the TCP near the cube.
    pub const REACH: RewardTerm = RewardTerm {
        name: "reach",
        info_key: "reward_reach",
        default_weight: 1.0,
        description: "`1 - tanh(5 d)`, `d` = distance from the TCP to the cube centre",
    };
    /// `grasp`: both fingers squeeze the cube.
    pub const GRASP: RewardTerm = RewardTerm {
        name: "grasp",
        info_key: "reward_grasp",
        default_weight: 1.0,
        description: "1 while both fingers squeeze the cube (`is_grasped`)",
    };
    /// `lift`: the cube off the floor.
    pub const LIFT: RewardTerm = RewardTerm {
        name: "lift",
        info_key: "reward_lift",
        default_weight: 1.0,
        description: "cube height above its floor resting height over the platform's height, \
                      clipped to [0, 1]",
    };
    /// `carry`: the cube near the goal.
    pub const CARRY: RewardTerm = RewardTerm {
        name: "carry",
        info_key: "reward_carry",
        default_weight: 2.0,
        description: "`1 - tanh(5 d)`, `d` = distance from the cube to the goal",
    };
    /// `place`: the cube placed.
    pub const PLACE: RewardTerm = RewardTerm {
        name: "place",
        info_key: "reward_place",
        default_weight: 5.0,
        description: "1 once the cube is placed: released, at rest, on the platform, within \
                      the threshold",
    };
    /// `release`: opening the hand with the cube at the goal (off by default).
    pub const RELEASE: RewardTerm = RewardTerm {
        name: "release",
        info_key: "reward_release",
        default_weight: 0.0,
        description: "the gripper opening the action commands (0 closed, 1 fully open) while \
                      the cube is within the threshold",
    };
}

/// The weight of every reward term a task can declare, resolved once per environment
/// ([`RewardWeights::resolve`]): each of the task's terms at its default or at what the
/// configuration's `reward_weights` sets; a term the task does not pay weighs 0. Every task
/// reads its weights from here (the staged cube reward's six, Stack's `stage`, Flip's
/// `orient`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RewardWeights {
    /// Weight of the `reach` term.
    pub reach: f64,
    /// Weight of the `grasp` term.
    pub grasp: f64,
    /// Weight of the `lift` term.
    pub lift: f64,
    /// Weight of the `carry` term.
    pub carry: f64,
    /// Weight of the `place` term.
    pub place: f64,
    /// Weight of the `release` term (0: off).
    pub release: f64,
    /// Weight of Stack's `stage` term (0: off).
    pub stage: f64,
    /// Weight of Flip's `orient` term.
    pub orient: f64,
    /// Weight of peg insertion's `align` term.
    pub align: f64,
    /// Weight of peg insertion's `insert` term.
    pub insert: f64,
    /// Weight of drawer opening's `open` term.
    pub open: f64,
}

impl RewardWeights {
    /// The weights of a task paying `terms`, with the configuration's `overrides` (already
    /// validated against `terms`).
    pub fn resolve(terms: &[RewardTerm], overrides: &BTreeMap<String, f64>) -> Self {
        let mut weights = Self::default();
        for t in terms {
            let weight = overrides.get(t.name).copied().unwrap_or(t.default_weight);
            match weights.slot_mut(t.name) {
                Some(slot) => *slot = weight,
                None => debug_assert!(false, "no weight for the reward term {:?}", t.name),
            }
        }
        weights
    }

    /// The weight of the term called `name` (0 for a name no task declares).
    pub fn get(&self, name: &str) -> f64 {
        let mut copy = *self;
        copy.slot_mut(name).map_or(0.0, |w| *w)
    }

    /// The weight of each of `terms` by name (what a resolved configuration spells out).
    pub fn named(&self, terms: &[RewardTerm]) -> BTreeMap<&'static str, f64> {
        terms.iter().map(|t| (t.name, self.get(t.name))).collect()
    }

    fn slot_mut(&mut self, name: &str) -> Option<&mut f64> {
        Some(match name {
            "reach" => &mut self.reach,
            "grasp" => &mut self.grasp,
            "lift" => &mut self.lift,
            "carry" => &mut self.carry,
            "place" => &mut self.place,
            "release" => &mut self.release,
            "stage" => &mut self.stage,
            "orient" => &mut self.orient,
            "align" => &mut self.align,
            "insert" => &mut self.insert,
            "open" => &mut self.open,
            _ => return None,
        })
    }
}

/// The goal-free inputs of the staged cube reward, as the cube tasks report them in the step
/// info (under the keys of [`RewardContext::KEYS`]).
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
    /// The gripper opening the last action commanded, from 0 (closed) to 1 (fully open); at
    /// reset, the measured opening.
    pub gripper_opening: f32,
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
    /// See the module table.
    pub release: f32,
    /// Stack's milestones (0 for every other task; see [`crate::task::stack`]).
    pub stage: f32,
}

impl RewardContext {
    /// The `release` term at weight `weight`: the weight times the commanded opening, clamped
    /// to [0, 1] (paid where the task's condition holds).
    pub fn release(&self, weight: f64) -> f32 {
        weight as f32 * self.gripper_opening.clamp(0.0, 1.0)
    }

    /// The info key of each field.
    pub const KEYS: [&'static str; 7] = [
        "reward_reach",
        "reward_grasp",
        "reward_lift",
        "gripper_opening",
        "cube_released",
        "cube_at_rest",
        "cube_on_platform",
    ];

    /// The context of one transition from a row of reward-context values laid out as `keys`
    /// (flags as 0 or 1); fields `keys` lacks keep their default (0, false).
    pub fn from_row(keys: &[&str], row: &[f32]) -> Self {
        let mut c = Self::default();
        for (key, &v) in keys.iter().zip(row) {
            match *key {
                "reward_reach" => c.reach = v,
                "reward_grasp" => c.grasp = v,
                "reward_lift" => c.lift = v,
                "gripper_opening" => c.gripper_opening = v,
                "cube_released" => c.cube_released = v != 0.0,
                "cube_at_rest" => c.cube_at_rest = v != 0.0,
                "cube_on_platform" => c.cube_on_platform = v != 0.0,
                _ => {}
            }
        }
        c
    }
}

impl RewardTerms {
    /// The dense reward: the terms summed in a fixed order (`release`, then `stage` last, so
    /// with their default weights of 0 the sum is bit for bit the five-term sum: no term is
    /// negative, and `x + 0.0` is `x` for every `x >= +0.0`).
    pub fn total(&self) -> f32 {
        self.reach + self.grasp + self.lift + self.carry + self.place + self.release + self.stage
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

/// A batched reward: checks the arguments ([`check_batch`]), then writes `reward(achieved,
/// desired, context row)` of each of the `n` transitions into `out`. `contexts` holds
/// `n x context_len` reward-context values (the task's `reward_context_keys`, flags as 0 or
/// 1), or nothing, when every row reads as zeros.
#[allow(clippy::too_many_arguments)]
pub fn compute_batch_with(
    achieved: &[f32],
    desired: &[f32],
    goal_dim: usize,
    contexts: &[f32],
    context_len: usize,
    needs_context: bool,
    out: &mut [f32],
    reward: impl Fn(&[f32], &[f32], &[f32]) -> f32,
) -> Result<()> {
    check_batch(
        achieved,
        desired,
        goal_dim,
        contexts,
        context_len,
        needs_context,
        out,
    )?;
    let zeros = vec![0.0f32; if contexts.is_empty() { context_len } else { 0 }];
    for (i, r) in out.iter_mut().enumerate() {
        let span = i * goal_dim..(i + 1) * goal_dim;
        let row = if contexts.is_empty() {
            &zeros[..]
        } else {
            &contexts[i * context_len..(i + 1) * context_len]
        };
        *r = reward(&achieved[span.clone()], &desired[span], row);
    }
    Ok(())
}

/// Checks the arguments of a batched reward for goals of `goal_dim` entries: `achieved` and
/// `desired` hold `n x goal_dim` finite values, `out` has room for `n` rewards and `contexts`
/// holds `n x context_len` finite values (or none, unless `needs_context` and there is a
/// context to give). Returns `n`.
pub fn check_batch(
    achieved: &[f32],
    desired: &[f32],
    goal_dim: usize,
    contexts: &[f32],
    context_len: usize,
    needs_context: bool,
    out: &[f32],
) -> Result<usize> {
    if achieved.len() % goal_dim != 0 {
        return Err(Error::WrongLength {
            what: format!("achieved_goal (n x {goal_dim})"),
            expected: (achieved.len() / goal_dim + 1) * goal_dim,
            got: achieved.len(),
        });
    }
    let n = achieved.len() / goal_dim;
    let desired_what = format!("desired_goal (n x {goal_dim})");
    crate::error::ensure_len(&desired_what, achieved.len(), desired.len())?;
    crate::error::ensure_len("reward output", n, out.len())?;
    if (needs_context && context_len > 0) || !contexts.is_empty() {
        crate::error::ensure_len("info entries", n * context_len, contexts.len())?;
    }
    if let Some(i) = contexts.iter().position(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            what: format!("info[{}] reward context", i / context_len.max(1)),
            value: contexts[i] as f64,
        });
    }
    for (name, values) in [("achieved_goal", achieved), ("desired_goal", desired)] {
        if let Some((i, &v)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Error::NonFinite {
                what: format!("{name}[{}][{}]", i / goal_dim, i % goal_dim),
                value: v as f64,
            });
        }
    }
    Ok(n)
}

/// [`closeness`]'s rate (per metre), panda-gym's.
pub const CLOSENESS_RATE: f64 = 5.0;

/// `1 - tanh(5 d)`: 1 at the target, 0.5 at 11 cm, fading to 0 beyond half a metre.
pub fn closeness(distance: f64) -> f32 {
    closeness_at_rate(distance, CLOSENESS_RATE)
}

/// `1 - tanh(rate d)`: [`closeness`] with another rate (per metre). A smaller rate pays, and
/// slopes, from farther away: with 2, 0.28 at 45 cm where [`closeness`] pays 0.02.
pub fn closeness_at_rate(distance: f64, rate: f64) -> f32 {
    (1.0 - (rate * distance).tanh()) as f32
}

/// The reward function of an environment: its type, success threshold and dense weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RewardFunction {
    /// Sparse or dense.
    pub reward_type: RewardType,
    /// Success threshold (m).
    pub success_threshold: f64,
    /// Weights of the dense terms. `reach`, `grasp` and `lift` arrive already weighted in the
    /// [`RewardContext`] (the environment applies them); the others are applied here.
    pub weights: RewardWeights,
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
                let w = &self.weights;
                let terms = RewardTerms {
                    reach: context.reach,
                    grasp: context.grasp,
                    lift: context.lift,
                    carry: w.carry as f32 * closeness(distance),
                    place: if is_placed { w.place as f32 } else { 0.0 },
                    release: if is_success {
                        context.release(w.release)
                    } else {
                        0.0
                    },
                    stage: 0.0,
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
    /// `contexts` `n` rows of the values of `keys` (may be empty for the sparse reward, which
    /// does not read them). Writes `n` rewards into `out`.
    pub fn compute_batch(
        &self,
        achieved: &[f32],
        desired: &[f32],
        keys: &[&str],
        contexts: &[f32],
        out: &mut [f32],
    ) -> Result<()> {
        let needs_context = self.reward_type == RewardType::Dense;
        compute_batch_with(
            achieved,
            desired,
            GOAL_DIM,
            contexts,
            keys.len(),
            needs_context,
            out,
            |a, d, row| {
                self.evaluate(a, d, &RewardContext::from_row(keys, row))
                    .reward
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn placed_context() -> RewardContext {
        RewardContext {
            reach: 1.0,
            grasp: 0.0,
            lift: 1.0,
            cube_released: true,
            cube_at_rest: true,
            cube_on_platform: true,
            gripper_opening: 1.0,
        }
    }

    fn pick_and_place_weights() -> RewardWeights {
        use cube_terms::*;
        RewardWeights::resolve(
            &[REACH, GRASP, LIFT, CARRY, PLACE, RELEASE],
            &BTreeMap::new(),
        )
    }

    fn dense() -> RewardFunction {
        RewardFunction {
            reward_type: RewardType::Dense,
            success_threshold: 0.05,
            weights: pick_and_place_weights(),
        }
    }

    fn row(c: &RewardContext) -> [f32; 7] {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        [
            c.reach,
            c.grasp,
            c.lift,
            c.gripper_opening,
            flag(c.cube_released),
            flag(c.cube_at_rest),
            flag(c.cube_on_platform),
        ]
    }

    #[test]
    fn sparse_is_minus_one_outside_the_threshold_and_zero_inside() {
        let f = RewardFunction {
            reward_type: RewardType::Sparse,
            ..dense()
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
        let f = dense();
        let goal = [0.5, 0.3, 0.125];
        let holding = RewardContext {
            reach: 1.0,
            grasp: 1.0,
            lift: 1.0,
            cube_released: false,
            cube_at_rest: true,
            cube_on_platform: false,
            gripper_opening: 0.0,
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
            weights: RewardWeights {
                release: 0.5,
                ..pick_and_place_weights()
            },
            ..dense()
        };
        let achieved = [0.5, 0.3, 0.125, 0.1, 0.1, 0.025];
        let desired = [0.5, 0.31, 0.125, 0.5, 0.3, 0.125];
        let contexts = [placed_context(), RewardContext::default()];
        let rows: Vec<f32> = contexts.iter().flat_map(row).collect();
        let keys = RewardContext::KEYS;
        let mut out = [0.0; 2];
        f.compute_batch(&achieved, &desired, &keys, &rows, &mut out)
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
            f.compute_batch(&achieved[..4], &desired[..4], &keys, &rows, &mut out),
            Err(Error::WrongLength { .. })
        ));
        assert!(matches!(
            f.compute_batch(&achieved, &desired, &keys, &[], &mut out),
            Err(Error::WrongLength { .. })
        ));
        assert!(matches!(
            f.compute_batch(&achieved, &desired, &keys, &rows[..13], &mut out),
            Err(Error::WrongLength { .. })
        ));
        let nan = [f32::NAN, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert!(matches!(
            f.compute_batch(&nan, &desired, &keys, &rows, &mut out),
            Err(Error::NonFinite { .. })
        ));
        let mut bad_rows = rows.clone();
        bad_rows[3] = f32::INFINITY;
        assert!(matches!(
            f.compute_batch(&achieved, &desired, &keys, &bad_rows, &mut out),
            Err(Error::NonFinite { .. })
        ));
    }

    #[test]
    fn weights_scale_their_terms_and_release_pays_only_at_the_goal() {
        let goal = [0.5, 0.3, 0.125];
        let off = [0.5, 0.4, 0.125];
        let mut held_on_goal = placed_context();
        held_on_goal.cube_released = false;
        held_on_goal.gripper_opening = 0.25;
        let default = dense().evaluate(&goal, &goal, &held_on_goal);
        assert_eq!(default.terms.release, 0.0);
        assert_eq!(default.terms.carry, 2.0);
        let weighted = RewardFunction {
            weights: RewardWeights {
                carry: 3.0,
                place: 7.0,
                release: 2.0,
                ..pick_and_place_weights()
            },
            ..dense()
        };
        let v = weighted.evaluate(&goal, &goal, &held_on_goal);
        assert_eq!(v.terms.carry, 3.0);
        assert_eq!(v.terms.release, 0.5);
        assert_eq!(v.reward, v.terms.total());
        assert_eq!(
            weighted
                .evaluate(&goal, &goal, &placed_context())
                .terms
                .place,
            7.0
        );
        // Off the goal: no release reward; held just above the platform: the same as on it.
        assert_eq!(
            weighted.evaluate(&off, &goal, &held_on_goal).terms.release,
            0.0
        );
        let mut lifted = held_on_goal;
        lifted.cube_on_platform = false;
        assert_eq!(weighted.evaluate(&goal, &goal, &lifted).terms.release, 0.5);
    }
}
