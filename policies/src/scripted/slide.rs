//! The `slide` task's expert: grasp the cube where it rests (the grasp sequence, `grasp.rs`),
//! slide it along the slippery floor towards the goal, speeding up until the speed it has would
//! carry it to the goal once let go, then let go while the hand keeps pace with it, lift the
//! hand clear and wait. A cube that stops short within reach is grasped and slid again.
//!
//! Why a held slide and not a strike: a cube struck through a contact with little friction
//! moves along the normal of the face that was hit, not along the hand's path, so its heading
//! depends on its yaw and on where the fingers meet it; held, it moves with the hand, and the
//! speed at the moment of letting go decides how far it slides (`v^2 / (2 mu g)`).

use nalgebra::Vector3;
use panda_rapier_core::task::TaskConfig;
use panda_rapier_core::Result;

use super::grasp::{self, GraspRules};
use super::{vector_at, Decision, Expert, ExpertContext, Phase};

impl Phase {
    /// `slide`: the held cube is slid towards the goal, speeding up.
    pub const SLIDE: Phase = Phase::new("slide");
    /// `slide`: the fingers open while the hand keeps pace with the cube and rises off it.
    pub const LET_GO: Phase = Phase::new("let_go");
    /// `slide`: the hand waits above while the cube slides (or rests beyond reach).
    pub const WAIT: Phase = Phase::new("wait");
}

/// Gravity (m/s^2) for the cube's deceleration on the floor.
const GRAVITY: f64 = 9.81;
/// The let-go cube's deceleration as a fraction of `floor_friction * g` (measured: a cube let
/// go at 0.75 m/s slid 0.73 m on the 0.04 floor, 0.385 m/s^2 against 0.392).
const DECELERATION_SCALE: f64 = 1.0;
/// Largest speed-up of the slide, in multiples of the let-go cube's deceleration: the hand
/// reaches a commanded speed within about one control step, so the ramp is the expert's, and
/// the slower the cube slows down the finer it must be.
const ACCELERATION: f64 = 8.0;
/// The hand is asked for this multiple of the exact speed: it reaches a little less than it is
/// asked for, and the cube must cross the exact speed (to be let go) while gaining slowly.
const SPEED_MARGIN: f64 = 1.1;
/// How far (m, per unit of the line's sideways slope) beside the goal the slide aims.
const AIM_CORRECTION: f64 = 0.12;
/// How far (m) short of the end of `ee_workspace` along x the hand lets go of a cube it could
/// not yet speed up enough.
const LAUNCH_REACH: f64 = 0.25;
/// Fastest slide (m/s).
const MAX_SPEED: f64 = 1.0;
/// Control steps from the decision to let go to the fingers leaving the cube (the finger drive
/// reverses from squeezing), during which the hand carries it on.
const LET_GO_STEPS: f64 = 1.5;
/// The cube is let go once the distance it would slide is within this much (m) of the goal.
const LET_GO_TOLERANCE: f64 = 0.02;
/// Cube speed (m/s) above which it counts as sliding.
const SLIDING_SPEED: f64 = 0.03;
/// Rate (m/s) at which the hand rises while letting go.
const RISE_SPEED: f64 = 0.4;
/// Height (m) of the TCP above the cube's centre at which the fingers are clear of it.
const CLEAR_HEIGHT: f64 = 0.06;
/// Height (m) above the cube's centre at which the hand waits.
const WAIT_HEIGHT: f64 = 0.12;
/// How far (m) inside the end of `ee_workspace` a resting cube's centre must be to be grasped
/// again.
const REACH_MARGIN: f64 = 0.04;

/// The `slide` task's expert (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct SlideExpert;

impl GraspRules for SlideExpert {}

impl SlideExpert {
    /// The let-go cube's deceleration (m/s^2) on this configuration's floor.
    fn deceleration(cx: &ExpertContext) -> f64 {
        let friction = match &cx.config().task {
            TaskConfig::Slide(section) => section.floor_friction,
            _ => 1.0,
        };
        DECELERATION_SCALE * friction * GRAVITY
    }
}

impl Expert for SlideExpert {
    fn decide(&self, cx: &ExpertContext, observation: &[f32]) -> Result<Decision> {
        let s = &cx.slots;
        let v3 = |r: &std::ops::Range<usize>| vector_at(observation, r);
        let cube = v3(&s.achieved);
        let goal = v3(&s.desired);
        let tcp = v3(&s.tcp);
        let cube_velocity = cx
            .slot("cube_linear_velocity")
            .map_or_else(Vector3::zeros, |r| v3(&r));
        let period = 1.0 / cx.config().control_frequency;
        let decision = |phase, tcp_target, gripper| Decision {
            hand: None,
            phase,
            tcp_target,
            speed: 1.0,
            gain: 1.0,
            gripper,
        };
        let sequence = grasp::decide(self, cx, observation)?;
        let held = [Phase::CARRY, Phase::LIFT, Phase::LOWER, Phase::HOLD].contains(&sequence.phase);
        let sliding = cube_velocity.xy().norm() > SLIDING_SPEED;
        // The fingers shut on the cube, whether or not they have settled (a sliding cube keeps
        // them moving a little). While they open after the decision to let go, the cube keeps
        // its speed and nears the goal, so the decision stands.
        let (around, squeezing) = grasp::hand_on_cube(cx, tcp, cube, observation[s.width] as f64);
        let gripping = around && squeezing;
        // Aim beside the goal: the cube's path comes out steeper than the line it is slid along,
        // by a fraction of the line's sideways slope (measured).
        let line = (goal - cube).xy();
        let unit = line / line.norm().max(1e-9);
        let left = nalgebra::Vector2::new(-unit.y, unit.x);
        let aim = goal.xy() - left * (AIM_CORRECTION * unit.y);
        let to_goal = aim - cube.xy();
        let distance = to_goal.norm();
        let heading = if distance > 1e-9 {
            to_goal / distance
        } else {
            to_goal
        };
        let deceleration = Self::deceleration(cx);
        // The hand moving on at `speed` along the line to the goal, rising at `rise`.
        let keep_pace = |speed: f64, rise: f64| {
            let step = heading * speed * period;
            Vector3::new(tcp.x + step.x, tcp.y + step.y, tcp.z + rise * period)
        };
        if gripping && (held || sliding) {
            // Where the cube would stop if let go now: the fingers leave it only about
            // `LET_GO_STEPS` control steps later, the hand keeping pace meanwhile.
            let v = cube_velocity.xy();
            let along = v.dot(&heading).max(0.0);
            let carried = LET_GO_STEPS * along * period;
            let travel = along * along / (2.0 * deceleration);
            // Past `LAUNCH_REACH` the arm, stretching out, can no longer speed the cube up:
            // let go whatever it would reach (short, it is grasped and slid again if it stops
            // within reach).
            let stretched = tcp.x > cx.config().ee_workspace[1][0] - LAUNCH_REACH;
            if travel >= distance - carried - LET_GO_TOLERANCE || stretched {
                return Ok(decision(Phase::LET_GO, keep_pace(along, 0.0), 1.0));
            }
            // The speed that, reached by the next step (the hand follows within about one)
            // and let go then, carries the cube exactly to the goal:
            // v^2 = 2 a (d - (1 + LET_GO_STEPS) v T).
            let (a, k) = (deceleration, (1.0 + LET_GO_STEPS) * period);
            let exact = -a * k + ((a * k).powi(2) + 2.0 * a * distance).sqrt();
            let wanted = (SPEED_MARGIN * exact)
                .min(along + ACCELERATION * deceleration * period)
                .min(MAX_SPEED);
            let step = heading * wanted * period;
            let target = Vector3::new(tcp.x + step.x, tcp.y + step.y, tcp.z);
            return Ok(decision(Phase::SLIDE, target, -1.0));
        }
        if sliding && tcp.z < cube.z + CLEAR_HEIGHT && (cube - tcp).xy().norm() < 0.1 {
            // The fingers are opening or still around the cube: keep pace, rising.
            return Ok(decision(
                Phase::LET_GO,
                keep_pace(cube_velocity.xy().dot(&heading).max(0.0), RISE_SPEED),
                1.0,
            ));
        }
        // Sliding away, or at rest beyond reach: wait above.
        if sliding || cube.x > cx.config().ee_workspace[1][0] - REACH_MARGIN {
            let above = Vector3::new(tcp.x, tcp.y, tcp.z.max(cube.z + WAIT_HEIGHT));
            return Ok(decision(Phase::WAIT, above, 1.0));
        }
        Ok(sequence)
    }
}
