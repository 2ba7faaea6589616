//! The grasp sequence of the experts that carry a cube (pick-and-place, lift, stack): open,
//! move above, descend, close, lift, carry, lower, release, retreat, each phase recognised from
//! where the hand, the fingers and the cube are. A task changes it through [`GraspRules`]:
//! which cube goes where, when the fingers count as holding it, how they close, and when to
//! let go and grasp again (`stack.rs`); the defaults are pick-and-place's.

use nalgebra::{Matrix3, Vector3};
use panda_rapier_core::Result;

use super::{vector_at, Decision, ExpertContext, Phase};

impl Phase {
    /// Opening the hand and moving above the cube.
    pub const APPROACH: Phase = Phase::new("approach");
    /// Lowering the open hand around the cube.
    pub const DESCEND: Phase = Phase::new("descend");
    /// Squeezing the cube.
    pub const CLOSE: Phase = Phase::new("close");
    /// Raising the held cube until it clears whatever lies on the way to the goal.
    pub const LIFT: Phase = Phase::new("lift");
    /// Moving the held cube above the goal.
    pub const CARRY: Phase = Phase::new("carry");
    /// Lowering the held cube onto the goal.
    pub const LOWER: Phase = Phase::new("lower");
    /// Opening the hand with the cube at the goal.
    pub const RELEASE: Phase = Phase::new("release");
    /// Moving the open hand up and away from the placed cube.
    pub const RETREAT: Phase = Phase::new("retreat");
    /// Holding the cube at a goal in the air (nothing to place it on).
    pub const HOLD: Phase = Phase::new("hold");
}

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

/// What a task changes in the grasp sequence; the defaults are pick-and-place's.
pub(super) trait GraspRules {
    /// The cube to handle now and where it goes (`cube` and `goal` are the goals' first three
    /// entries).
    fn target(
        &self,
        cx: &ExpertContext,
        _observation: &[f32],
        cube: Vector3<f64>,
        goal: Vector3<f64>,
        _tcp: Vector3<f64>,
    ) -> Target {
        cx.single_target(cube, goal)
    }

    /// Whether squeezing fingers `width` apart are on the cube (not still closing on it).
    fn touching(&self, _cx: &ExpertContext, _width: f64, _grip: &Grip) -> bool {
        true
    }

    /// Whether the grasp has settled, the fingers moving at most `finger_speed`.
    fn steady(&self, _cx: &ExpertContext, finger_speed: f64, _cube: Vector3<f64>) -> bool {
        finger_speed < 0.02
    }

    /// A decision that overrides the sequence (letting go to grasp again), if any.
    #[allow(clippy::too_many_arguments)]
    fn regrasp(
        &self,
        _cx: &ExpertContext,
        _target: &Target,
        _grip: &Grip,
        _tcp: Vector3<f64>,
        _width: f64,
        _around_cube: bool,
        _held_or_open: bool,
    ) -> Option<Decision> {
        None
    }

    /// The gripper command that closes the hand on the cube.
    fn close_command(&self, _cx: &ExpertContext, _width: f64, _grip: &Grip) -> f32 {
        -1.0
    }
}

/// Whether the hand is around `cube` (centred on it within `in_hand_tolerance`, level with it
/// within `in_hand_height`) and whether its fingers, `width` apart, squeeze something (short of
/// fully open, wider than half the cube).
pub(super) fn hand_on_cube(
    cx: &ExpertContext,
    tcp: Vector3<f64>,
    cube: Vector3<f64>,
    width: f64,
) -> (bool, bool) {
    let p = &cx.params;
    let relative = cube - tcp;
    let around = relative.xy().norm() < p.in_hand_tolerance && relative.z.abs() < p.in_hand_height;
    let squeezing = width < 0.9 * cx.open_width && width > 0.5 * cx.cube_half;
    (around, squeezing)
}

/// The sequence's decision for one checked observation, under `rules`.
pub(super) fn decide(
    rules: &dyn GraspRules,
    cx: &ExpertContext,
    observation: &[f32],
) -> Result<Decision> {
    let s = &cx.slots;
    let p = &cx.params;
    let v3 = |r: &std::ops::Range<usize>| vector_at(observation, r);
    let cube = v3(&s.achieved);
    let goal = v3(&s.desired);
    let tcp = v3(&s.tcp);
    let width = observation[s.width] as f64;
    let horizontal = |v: Vector3<f64>| v.xy().norm();
    let target = rules.target(cx, observation, cube, goal, tcp);
    let (cube, goal, goal_surface, hover_height, careful) = (
        target.cube,
        target.goal,
        target.goal_surface,
        target.hover_height,
        target.careful,
    );
    let relative = cube - tcp;
    let tcp_speed = v3(&s.tcp_velocity).norm();
    let finger_speed = cx
        .finger_slots()
        .map(|i| (observation[s.joint_velocities.start + i] as f64).abs())
        .fold(0.0, f64::max);

    let (around_cube, squeezing) = hand_on_cube(cx, tcp, cube, width);
    // Fingers short of fully open: closing, squeezing something, or shut on nothing.
    let hand_closed = width < 0.9 * cx.open_width;
    // And the task's rules: `stack` asks for the fingers on the cube (not still closing on
    // it), and keeps a cube off the surface under it held even while the fingers jiggle.
    let grip = cx.grip(target.rotation.as_ref());
    let touching = rules.touching(cx, width, &grip);
    let steady = rules.steady(cx, finger_speed, cube);
    let held = around_cube && squeezing && touching && steady;
    let air_goal = goal.z > goal_surface + cx.cube_half + 0.01;
    let cube_to_goal = (cube - goal).norm();

    let decision = |phase, tcp_target, speed, gripper| Decision {
        hand: None,
        phase,
        tcp_target,
        speed,
        gain: match phase {
            Phase::DESCEND | Phase::LOWER => p.arrival_gain,
            _ => 1.0,
        },
        gripper,
    };
    let held_or_open = held || !squeezing;
    if let Some(d) = rules.regrasp(cx, &target, &grip, tcp, width, around_cube, held_or_open) {
        return Ok(d);
    }
    if held {
        let offset_to_tcp = -relative;
        let off_goal = horizontal(goal - cube);
        let place_tolerance = if careful {
            p.stack_place_tolerance
        } else {
            p.place_tolerance
        };
        // Onto a stack, the cube goes down only once the hand has stopped moving sideways
        // (arriving at speed, the arm overshoots and puts it down on the bottom one's edge).
        let sliding = careful && v3(&s.tcp_velocity).xy().norm() > p.settle_speed;
        if off_goal > place_tolerance || sliding {
            // Carry at the goal's height plus clearance, never lower than the cube is now,
            // and move sideways only where the cube clears every surface on the way.
            let carry_z = (goal.z + if air_goal { 0.0 } else { 0.03 }).max(cube.z);
            let step = (goal - cube)
                .xy()
                .map(|d| d.clamp(-cx.config.ee_step, cx.config.ee_step));
            let clear = cx.clears_surfaces(cube, step.x, step.y);
            let (phase, target) = if off_goal < p.arrival_distance {
                // Close over the goal: come down along a funnel while lining up, so the
                // cube meets the surface only once it is over the goal.
                let z = if air_goal {
                    goal.z
                } else if sliding {
                    cube.z
                } else {
                    (goal.z + 2.0 * off_goal).min(cube.z)
                };
                (Phase::LOWER, Vector3::new(goal.x, goal.y, z))
            } else if clear {
                (Phase::CARRY, Vector3::new(goal.x, goal.y, carry_z))
            } else {
                let z = carry_z.max(cube.z + 0.05);
                (Phase::LIFT, Vector3::new(cube.x, cube.y, z))
            };
            return Ok(decision(phase, target + offset_to_tcp, 1.0, -1.0));
        }
        if air_goal {
            return Ok(decision(Phase::HOLD, goal + offset_to_tcp, 1.0, -1.0));
        }
        // The environment keeps the hand a clearance above surfaces; a cube held low in
        // the hand is let go from there (a few millimetres' drop).
        let hand_floor = cx.config.surface_height(tcp.x, tcp.y) + cx.config.ee_surface_clearance;
        let hand_lowest = tcp.z < hand_floor + 0.003;
        if cube.z - goal.z > p.release_height && !hand_lowest {
            return Ok(decision(Phase::LOWER, goal + offset_to_tcp, 1.0, -1.0));
        }
        return Ok(decision(Phase::RELEASE, tcp, 0.0, 1.0));
    }
    if cube_to_goal < cx.config.success_threshold && !air_goal {
        // Placed (or being let go): open, then back off upwards.
        if hand_closed && around_cube {
            return Ok(decision(Phase::RELEASE, tcp, 1.0, 1.0));
        }
        let up = Vector3::new(tcp.x, tcp.y, goal.z + p.retreat_height);
        return Ok(decision(Phase::RETREAT, up, 1.0, 1.0));
    }
    let misalignment = horizontal(relative);
    let at_cube_height = tcp.z - cube.z < p.in_hand_tolerance;
    let settled = tcp_speed < p.settle_speed;
    let centred = misalignment < p.in_hand_tolerance - 0.01;
    if around_cube && (hand_closed || (centred && at_cube_height && settled)) {
        // Squeeze with the hand held still: a hand still moving, or chasing the cube while
        // the fingers push it, shoves the cube out of the grasp.
        let gripper = rules.close_command(cx, width, &grip);
        return Ok(decision(Phase::CLOSE, tcp, 0.0, gripper));
    }
    if around_cube && centred && at_cube_height {
        // In place but still moving: let the hand come to rest over the cube.
        return Ok(decision(Phase::DESCEND, cube, 1.0, 1.0));
    }
    if hand_closed {
        // A closed hand away from the cube (a missed or lost grasp): open it, rising to
        // the approach height while it opens.
        let up = Vector3::new(tcp.x, tcp.y, tcp.z.max(cube.z + hover_height));
        return Ok(decision(Phase::APPROACH, up, 1.0, 1.0));
    }
    // Come in along a funnel over the cube: straight down once lined up, otherwise high
    // enough that the open fingers pass over the cube's top.
    let sideways_settled = !careful || v3(&s.tcp_velocity).xy().norm() < p.settle_speed;
    if misalignment <= p.align_tolerance && sideways_settled {
        return Ok(decision(Phase::DESCEND, cube, 1.0, 1.0));
    }
    let mut height = (0.045 + 0.5 * (misalignment - p.align_tolerance)).min(hover_height);
    if misalignment < 2.5 * p.align_tolerance && tcp.z > cube.z + p.in_hand_height {
        // Nearly lined up and clear of the cube: hold the height while the hand centres,
        // rather than bouncing up the funnel after every small sideways wobble.
        height = height.min(tcp.z - cube.z);
    }
    let above = Vector3::new(cube.x, cube.y, cube.z + height);
    // Arriving sideways at the second cube of a stack, slow down near it: at full speed the
    // lagging arm dips below its target and sweeps the cube away.
    let speed = if careful && misalignment < p.stack_slow_distance {
        p.stack_approach_speed
    } else {
        1.0
    };
    Ok(decision(Phase::APPROACH, above, speed, 1.0))
}
