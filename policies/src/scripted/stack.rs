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
//!   `mod.rs`, `sliding`);
//! - a hand nearer the second cube than the first is going for it: a top cube that fell next to
//!   the stack is picked up again instead of the hand bouncing between the two.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::{vector_at, Decision, Phase, ScriptedPolicy};

/// The cube the policy handles now and where it goes.
#[derive(Debug, Clone, Copy)]
pub(super) struct Target {
    /// The cube's centre.
    pub cube: Vector3<f64>,
    /// Where its centre goes.
    pub goal: Vector3<f64>,
    /// The surface it is put down on: the platform or floor under the goal, or, for the top
    /// cube of a stack, the bottom cube.
    pub goal_surface: f64,
    /// Height of the hand above the cube while it moves in from afar.
    pub hover_height: f64,
    /// The second cube of a stack, reached from the side at speed, where the hand goes down
    /// only once it has stopped moving sideways.
    pub careful: bool,
    /// The cube's rotation, where the policy uses it (`stack`).
    pub rotation: Option<Matrix3<f64>>,
}

/// How the cube sits in or under the hand.
#[derive(Debug, Clone, Copy)]
pub(super) struct Grip {
    /// Cosine of the angle between the vertical and the cube's axis nearest to it: 1 when the
    /// cube rests on any face.
    pub upright: f64,
    /// The cube's width across the fingers (m).
    pub extent: f64,
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

impl ScriptedPolicy {
    /// `stack`: the cube to handle now. `cube` and `goal` are the first cube's.
    pub(super) fn stack_target(
        &self,
        observation: &[f32],
        cube: Vector3<f64>,
        goal: Vector3<f64>,
        tcp: Vector3<f64>,
    ) -> Target {
        let s = &self.slots;
        let p = &self.params;
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
        let first_done = (cube - goal).norm() < self.config.success_threshold
            && (holding_second || !low_at_first);
        if first_done {
            // Put the top cube where the bottom one is, not where its goal is: a stack must
            // line up, and the bottom cube is within the threshold of its goal.
            let on_top = Vector3::new(cube.x, cube.y, goal2.z.max(cube.z + 2.0 * self.cube_half));
            Target {
                cube: cube2,
                goal: on_top,
                goal_surface: cube.z + self.cube_half,
                hover_height: p.stack_hover_height,
                careful: true,
                rotation: rotation(1),
            }
        } else {
            Target {
                rotation: rotation(0),
                ..self.single_target(cube, goal)
            }
        }
    }

    /// How `rotation` (the cube's, if known) sits under the hand.
    pub(super) fn grip(&self, rotation: Option<&Matrix3<f64>>) -> Grip {
        let size = 2.0 * self.cube_half;
        let Some(m) = rotation else {
            return Grip {
                upright: 1.0,
                extent: size,
            };
        };
        // The fingers close along the hand's y axis.
        let closing = self.hand_down * Vector3::y();
        Grip {
            upright: (0..3).map(|i| m[(2, i)].abs()).fold(0.0, f64::max),
            extent: size * (0..3).map(|i| m.column(i).dot(&closing).abs()).sum::<f64>(),
        }
    }

    /// `stack`: whether the cube's centre is more than `stack_aloft_height` above its resting
    /// height on the surface under it.
    pub(super) fn aloft(&self, cube: Vector3<f64>) -> bool {
        cube.z - self.config.surface_height(cube.x, cube.y)
            > self.cube_half + self.params.stack_aloft_height
    }

    /// `stack`: the gripper command that closes the hand on a cube `extent` wide across the
    /// fingers: first to just short of it, then squeezing.
    pub(super) fn stack_close_command(&self, width: f64, extent: f64) -> f32 {
        let p = &self.params;
        if width > extent + p.stack_squeeze_from {
            ((extent + p.stack_close_gap) / (self.open_width / 2.0) - 1.0) as f32
        } else {
            -1.0
        }
    }

    /// `stack`: a cube just picked up (still low over the surface it came from, away from its
    /// goal) and held tilted, pinched by two edges, would land on the stack on an edge and
    /// topple off: the hand lets it go where it is and rises off it, so that it falls flat and
    /// is grasped again. `None` when that is not the case.
    pub(super) fn stack_regrasp(
        &self,
        target: &Target,
        grip: &Grip,
        tcp: Vector3<f64>,
        width: f64,
        around_cube: bool,
        held_or_open: bool,
    ) -> Option<Decision> {
        let p = &self.params;
        let cube = target.cube;
        let just_picked = cube.z - self.config.surface_height(cube.x, cube.y)
            < self.cube_half + p.stack_regrasp_height
            && horizontal(target.goal - cube) > p.arrival_distance;
        if grip.upright >= p.stack_max_tilt.cos() || !just_picked || !around_cube || !held_or_open {
            return None;
        }
        let decision = |phase, tcp_target, speed| Decision {
            phase,
            tcp_target,
            speed,
            gain: 1.0,
            gripper: 1.0,
        };
        if width < 0.95 * self.open_width {
            return Some(decision(Phase::Release, tcp, 0.0));
        }
        let up = Vector3::new(tcp.x, tcp.y, cube.z + target.hover_height);
        Some(decision(Phase::Retreat, up, 1.0))
    }
}
