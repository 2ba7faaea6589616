//! The `stack` task's part of the scripted policy: which cube to handle and where it goes, and
//! the grasp rules that keep the top cube flat in the hand.
//!
//! Stack is pick-and-place twice: the first cube onto the goal on the platform, then the second
//! onto the first. Which stage is running is read off the observation like every other phase.
//! What differs from pick-and-place is that the top cube must arrive flat and slowly: in 1,000
//! `ee` episodes on the dynamic arm (seeds 0-999) before the rules below, 19 of the 26 failures
//! were a top cube that slid off the stack after the release, nearly all of them carried tilted
//! (pinched by two edges, 0.15-1.6 rad) and a few let go 1-5 cm above the bottom cube. The
//! rules, each guarded by the task (the other tasks' actions are unchanged):
//!
//! - the fingers close in two steps, first to just short of the cube's width across them, then
//!   squeeze: slammed shut from fully open they dug into a turned cube's edges and tipped it by
//!   more than 0.2 rad in 22 % of the grasps (5 % with the two steps);
//! - a cube that is nonetheless held tilted right after the grasp is let go where it is and
//!   grasped again;
//! - a squeezed cube off the surface under it counts as held whatever the fingers' speed (taken
//!   for let go while the fingers jiggled, it was released over the stack in mid-air);
//! - the top cube goes down onto the stack only once the hand has stopped moving sideways (in
//!   `grasp.rs`, `sliding`);
//! - a hand nearer the second cube than the first is going for it: a top cube that fell next to
//!   the stack is picked up again instead of the hand bouncing between the two.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::grasp::{self, GraspRules, Grip, Target};
use super::{vector_at, Decision, Expert, ExpertContext, Phase};
use panda_rapier_core::Result;

/// The `stack` task's expert: the grasp sequence twice, with the rules above.
#[derive(Debug, Clone, Copy, Default)]
pub struct StackExpert;

impl Expert for StackExpert {
    fn decide(&self, cx: &ExpertContext, observation: &[f32]) -> Result<Decision> {
        grasp::decide(self, cx, observation)
    }
}

/// A cube's rotation matrix from its quaternion slot (x, y, z, w).
fn rotation_at(observation: &[f32], slot: &std::ops::Range<usize>) -> Matrix3<f64> {
    let q = &observation[slot.start..slot.start + 4];
    let q = nalgebra::Quaternion::new(q[3] as f64, q[0] as f64, q[1] as f64, q[2] as f64);
    *UnitQuaternion::from_quaternion(q)
        .to_rotation_matrix()
        .matrix()
}

fn horizontal(v: Vector3<f64>) -> f64 {
    v.xy().norm()
}

impl GraspRules for StackExpert {
    /// The cube to handle now. `cube` and `goal` are the first cube's.
    fn target(
        &self,
        cx: &ExpertContext,
        observation: &[f32],
        cube: Vector3<f64>,
        goal: Vector3<f64>,
        tcp: Vector3<f64>,
    ) -> Target {
        let s = &cx.slots;
        let p = &cx.params;
        let cube2 = vector_at(observation, &(s.achieved.start + 3..s.achieved.end));
        let goal2 = vector_at(observation, &(s.desired.start + 3..s.desired.end));
        let rotation = |k: usize| {
            s.stack_orientations
                .as_ref()
                .map(|o| rotation_at(observation, &o[k]))
        };
        // The bottom cube is done once it is at its goal and the hand is not low beside it
        // (still holding it, letting go, or rising): a hand heading sideways for the other
        // cube from there would sweep the bottom one off the platform. Carrying the other cube
        // onto the stack does not count as undone, nor does a hand nearer the other cube than
        // the bottom one (going for it where it fell off the stack, next to the bottom one).
        let holding_second = horizontal(cube2 - tcp) < p.in_hand_tolerance
            && (cube2.z - tcp.z).abs() < p.in_hand_height;
        let low_at_first = horizontal(cube - tcp) < p.stack_clear_distance
            && tcp.z - cube.z < p.in_hand_height + 0.03
            && horizontal(cube - tcp) <= horizontal(cube2 - tcp);
        let first_done =
            (cube - goal).norm() < cx.config.success_threshold && (holding_second || !low_at_first);
        if first_done {
            // Put the top cube where the bottom one is, not where its goal is: a stack must
            // line up, and the bottom cube is within the threshold of its goal.
            let on_top = Vector3::new(cube.x, cube.y, goal2.z.max(cube.z + 2.0 * cx.cube_half));
            Target {
                cube: cube2,
                goal: on_top,
                goal_surface: cube.z + cx.cube_half,
                hover_height: p.stack_hover_height,
                careful: true,
                rotation: rotation(1),
            }
        } else {
            Target {
                rotation: rotation(0),
                ..cx.single_target(cube, goal)
            }
        }
    }

    /// Squeezing fingers count as holding the cube once they are on it, not still closing.
    fn touching(&self, cx: &ExpertContext, width: f64, grip: &Grip) -> bool {
        width < grip.extent + cx.params.stack_touch_margin
    }

    /// A cube more than `stack_aloft_height` above its resting height on the surface under it
    /// stays held even while the fingers jiggle (taken for let go, it would be released in
    /// mid-air over the stack).
    fn steady(&self, cx: &ExpertContext, finger_speed: f64, cube: Vector3<f64>) -> bool {
        let aloft = cube.z - cx.config.surface_height(cube.x, cube.y)
            > cx.cube_half + cx.params.stack_aloft_height;
        finger_speed < 0.02 || aloft
    }

    /// Closes the hand on a cube `grip.extent` wide across the fingers: first to just short
    /// of it, then squeezing.
    fn close_command(&self, cx: &ExpertContext, width: f64, grip: &Grip) -> f32 {
        let p = &cx.params;
        let extent = grip.extent;
        if width > extent + p.stack_squeeze_from {
            ((extent + p.stack_close_gap) / (cx.open_width / 2.0) - 1.0) as f32
        } else {
            -1.0
        }
    }

    /// A cube just picked up (still low over the surface it came from, away from its goal)
    /// and held tilted, pinched by two edges, would land on the stack on an edge and topple
    /// off: the hand lets it go where it is and rises off it, so that it falls flat and is
    /// grasped again. `None` when that is not the case.
    fn regrasp(
        &self,
        cx: &ExpertContext,
        target: &Target,
        grip: &Grip,
        tcp: Vector3<f64>,
        width: f64,
        around_cube: bool,
        held_or_open: bool,
    ) -> Option<Decision> {
        let p = &cx.params;
        let cube = target.cube;
        let just_picked = cube.z - cx.config.surface_height(cube.x, cube.y)
            < cx.cube_half + p.stack_regrasp_height
            && horizontal(target.goal - cube) > p.arrival_distance;
        if grip.upright >= p.stack_max_tilt.cos() || !just_picked || !around_cube || !held_or_open {
            return None;
        }
        let decision = |phase, tcp_target, speed| Decision {
            hand: None,
            phase,
            tcp_target,
            speed,
            gain: 1.0,
            gripper: 1.0,
        };
        if width < 0.95 * cx.open_width {
            return Some(decision(Phase::RELEASE, tcp, 0.0));
        }
        let up = Vector3::new(tcp.x, tcp.y, cube.z + target.hover_height);
        Some(decision(Phase::RETREAT, up, 1.0))
    }
}
