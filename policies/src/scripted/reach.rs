//! The `reach` task's expert: no cube, the open hand straight to the goal, slowing down on
//! arrival.

use panda_rapier_core::Result;

use super::{vector_at, Decision, Expert, ExpertContext, Phase};

impl Phase {
    /// Moving the hand to the goal.
    pub const REACH: Phase = Phase::new("reach");
}

/// The `reach` task's expert (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct ReachExpert;

impl Expert for ReachExpert {
    fn decide(&self, cx: &ExpertContext, observation: &[f32]) -> Result<Decision> {
        let p = &cx.params;
        let goal = vector_at(observation, &cx.slots.desired);
        let tcp = vector_at(observation, &cx.slots.tcp);
        let gain = if (goal - tcp).norm() < p.arrival_distance {
            p.arrival_gain
        } else {
            1.0
        };
        Ok(Decision {
            hand: None,
            phase: Phase::REACH,
            tcp_target: goal,
            speed: 1.0,
            gain,
            gripper: 1.0,
        })
    }
}
