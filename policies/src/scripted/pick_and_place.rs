//! The `pick_and_place` task's expert, also `lift`'s: the grasp sequence (`grasp.rs`) with its
//! default rules. With the goal in the air (lift, or pick-and-place's air goals) the cube is
//! held there instead of put down.

use panda_rapier_core::Result;

use super::grasp::{self, GraspRules};
use super::{Decision, Expert, ExpertContext};

/// The `pick_and_place` and `lift` tasks' expert (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct PickAndPlaceExpert;

impl GraspRules for PickAndPlaceExpert {}

impl Expert for PickAndPlaceExpert {
    fn decide(&self, cx: &ExpertContext, observation: &[f32]) -> Result<Decision> {
        grasp::decide(self, cx, observation)
    }
}
