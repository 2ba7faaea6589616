//! [`PickObjectExpert`]: picks the object up by the top-down grasp the task plans for it (the
//! observation's `grasp_position`, `grasp_direction` and `grasp_width`), turning the hand so
//! the fingers close along the grasp's direction, and carries it to the goal: the grasp
//! sequence of the cube experts (open, move above, descend, close, lift, carry, lower, release,
//! retreat) with the grasp point in the cube's place. Like every expert it is stateless: each
//! step it reads where the grasp point, the object and the hand are, so an object that slipped
//! or a grasp that missed starts the approach again.
//!
//! The hand turns only in `ee_pose` and `joints` control (the task's ids); in `ee` control it
//! stays at `hand_down`, and the expert succeeds only with grasps that happen to lie near it.

use nalgebra::{UnitQuaternion, Vector3};
use panda_rapier_core::task::flip::quaternion;
use panda_rapier_core::{Error, Result};

use super::{vector_at, wrap_half_turn, Decision, Expert, ExpertContext, Phase};

/// The scripted expert of `pick_object` (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct PickObjectExpert;

/// Height (m) of the fingertips above the object's top while the hand comes in sideways.
const OVER_TOP: f64 = 0.03;
/// How far below the TCP the fingertips reach (m): the Panda's pads.
const FINGERTIPS: f64 = 0.0084;
/// The open hand goes down onto the grasp once within this distance (m) of it sideways:
/// planned grasps keep the fingers only a few millimetres clear of the object's other parts.
const LINED_UP: f64 = 0.01;
/// The hand counts as turned to the grasp within this yaw (rad).
const TURNED: f64 = 0.08;
/// The TCP counts as at the grasp within this distance (m) sideways...
const AT_GRASP_SIDEWAYS: f64 = 0.008;
/// ...and this distance (m) up or down.
const AT_GRASP_HEIGHT: f64 = 0.008;
/// The grasp point stays within this distance (m) of a TCP that holds the object.
const IN_HAND: f64 = 0.03;
/// Speed (fraction of a full action) of the open hand's descent onto the grasp.
const DESCEND_SPEED: f64 = 0.5;
/// Speed of the open hand rising off the placed object until its fingertips clear it.
const RETREAT_SPEED: f64 = 0.3;
/// An object is off the ground with the lowest corner of its box this high (m) above the
/// surface under it.
const ALOFT: f64 = 0.004;
/// A held object that has landed is let go once it moves slower than this (m/s) relative to
/// the hand.
const LANDED_SPEED: f64 = 0.05;
/// Letting go, the hand rises this much (m)...
const UNJAM_RISE: f64 = 0.003;
/// ...at this speed (fraction of a full action), unless the object is slender: higher than
/// this many times its narrow side.
const UNJAM_SPEED: f64 = 0.1;
/// (See [`UNJAM_SPEED`].)
const SLENDER: f64 = 2.0;
/// A held object counts as settled moving slower than this (m/s) relative to the hand.
const SETTLED_SWING: f64 = 0.03;
/// Closing fingers slower than this (m/s) are stopped by what they touch.
const BLOCKED_FINGERS: f64 = 0.005;
/// An object stands upright with its z axis within this cosine of vertical (about 4 degrees)...
const UPRIGHT: f64 = 0.9975;
/// ...or its centre is within this (m) of its resting height; else it is pressed down by at
/// most...
const ON_BASE: f64 = 0.003;
/// ...this much (m)...
const MAX_PRESS: f64 = 0.012;
/// ...at this speed (fraction of a full action).
const PRESS_SPEED: f64 = 0.2;
/// The grasp counts as settled with the fingers moving slower than this (m/s).
const STEADY_FINGERS: f64 = 0.05;
/// Objects whose centre lies within this (m) of the grasp are carried at full speed...
const SWING_LEVER: f64 = 0.03;
/// ...and those whose centre lies within this (m) of it sideways...
const SIDE_LEVER: f64 = 0.02;
/// ...and none slower than this (fraction of a full action).
const MIN_CARRY_SPEED: f64 = 0.25;
/// The fingers close to the grasp's width (slowing as they arrive: slammed shut from wide
/// open they pass through a mug's wall or a bowl's rim), and squeeze once within this (m) of
/// it, or once something stops them...
const PRE_CLOSE_GAP: f64 = 0.004;
/// ...and fingers squeezing within this (m) of it hold the object.
const SQUEEZE_BAND: f64 = 0.015;
/// The carried object's lowest point keeps this far (m) above the platform's top.
const CARRY_CLEARANCE: f64 = 0.03;

impl Expert for PickObjectExpert {
    fn decide(&self, cx: &ExpertContext, observation: &[f32]) -> Result<Decision> {
        let slot = |name: &str| {
            cx.slot(name).ok_or_else(|| Error::InvalidConfig {
                field: "task".into(),
                reason: format!("the pick-object expert needs the `{name}` observation slot"),
            })
        };
        let v3 = |name: &str| slot(name).map(|r| vector_at(observation, &r));
        let s = &cx.slots;
        let p = &cx.params;
        let config = cx.config();
        let tcp = vector_at(observation, &s.tcp);
        let tcp_speed = vector_at(observation, &s.tcp_velocity).norm();
        let width = observation[s.width] as f64;
        let centre = vector_at(observation, &s.achieved);
        let goal = vector_at(observation, &s.desired);
        let half = v3("object_half_extents")?;
        let grasp = v3("grasp_position")?;
        let direction = slot("grasp_direction")?;
        let grasp_width = slot("grasp_width").map(|r| observation[r.start] as f64)?;
        let hand = quaternion(&observation[slot("tcp_orientation")?]);
        let finger_speed = cx
            .finger_slots()
            .map(|i| (observation[s.joint_velocities.start + i] as f64).abs())
            .fold(0.0, f64::max);

        // The grasp's closing yaw (the direction without its sense) and the hand's turn from
        // `hand_down` that closes the fingers (the hand's y axis) along it: the nearer of the two.
        let closing_yaw = 0.5
            * (observation[direction.start + 1] as f64).atan2(observation[direction.start] as f64);
        let closing_down = cx.hand_down * Vector3::y();
        let yaw_of = |v: Vector3<f64>| v.y.atan2(v.x);
        let turn = wrap_half_turn(closing_yaw - yaw_of(closing_down));
        let hand_target = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), turn) * cx.hand_down;
        let closing_now = hand * Vector3::y();
        let yaw_error = wrap_half_turn(closing_yaw - yaw_of(closing_now)).abs();

        // The lowest the TCP may go: the environment keeps end-effector targets a clearance
        // above surfaces (not in joint control); the grasp is taken there when planned lower.
        let surface = config.surface_height(grasp.x, grasp.y);
        let lowest = match config.control_mode {
            panda_rapier_core::env::ControlMode::Joints => surface + FINGERTIPS + 0.003,
            _ => surface + config.ee_surface_clearance + 0.001,
        };
        let grasp_at = Vector3::new(grasp.x, grasp.y, grasp.z.max(lowest));

        // Lifting and carrying, the hand keeps its yaw (the grasp turns with the object, and
        // following it would spin both) and levels.
        let keep_yaw = {
            use std::f64::consts::PI;
            let t = (yaw_of(closing_now) - yaw_of(closing_down) + PI).rem_euclid(2.0 * PI) - PI;
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), t) * cx.hand_down
        };
        let decision = |phase, tcp_target, speed, gain, gripper| Decision {
            phase,
            tcp_target,
            speed,
            gain,
            gripper,
            hand: Some(match phase {
                Phase::APPROACH | Phase::DESCEND => hand_target,
                Phase::LIFT | Phase::CARRY | Phase::CLOSE => keep_yaw,
                // Setting down and letting go, the hand does not turn at all: turning fingers
                // swing a held object and shove a released one.
                _ => hand,
            }),
        };
        let to_grasp = grasp_at - tcp;
        let around = (grasp - tcp).norm() < IN_HAND;
        let hand_closed = width < 0.9 * cx.open_width;
        // Within the band the fingers are told to squeeze: stopped there, they squeeze
        // something.
        // (Fingers stopped short of it are blocked by the object, turned or fallen since the
        // plan: they squeeze what they met.)
        let blocked = finger_speed < BLOCKED_FINGERS;
        let squeezing = hand_closed
            && width > 0.5 * grasp_width
            && (width <= grasp_width + SQUEEZE_BAND || blocked);
        // The lowest corner of the object's box, however it is turned.
        let rotation = quaternion(&observation[slot("object_orientation")?]);
        let m = rotation.to_rotation_matrix();
        let reach_down: f64 = (0..3).map(|i| m[(2, i)].abs() * half[i]).sum();
        let lowest = centre.z - reach_down;
        let aloft = lowest > config.surface_height(centre.x, centre.y) + ALOFT;
        // Tilted and propped up on an edge above its resting height (at the goal's height:
        // it landed tilted)?
        let tilted_up = m[(2, 2)] < UPRIGHT && centre.z - goal.z > ON_BASE;
        // Settled fingers squeeze it; once it is off the ground, fingers jiggling under its
        // swing still hold it (stopping to re-close would swing it more), and so do fingers
        // jiggling on an object that landed tilted (it is pressed onto its base first).
        let held = around && squeezing && (finger_speed < STEADY_FINGERS || aloft || tilted_up);

        let platform_top = config.surface_height(goal.x, goal.y);
        // Letting go, the hand rises a little, slowly, and off a platform its fingertips were
        // pressed onto (in joint control nothing keeps them off it): fingers pressed onto the
        // platform, or into a bowl's curve, cannot slide open. (Not off a slender object, a
        // bottle by its neck: lifted by the top as the pads open, it tips over.)
        let slender = half.z > SLENDER * half.x.min(half.y);
        let rise = if slender { 0.0 } else { UNJAM_RISE };
        let unjammed = Vector3::new(
            tcp.x,
            tcp.y,
            (tcp.z + rise).max(platform_top + FINGERTIPS + 0.002),
        );
        if held {
            // Where the object's centre goes, and the hand with it.
            let offset = tcp - centre;
            let bottom = centre.z - half.z;
            let off_goal = (goal - centre).xy().norm();
            // Over the goal, a swinging object is held still until it settles: lowered or let
            // go swinging, a tall one lands on its edge and topples.
            // (A swing moves the object's centre relative to the hand; a ball turning between
            // the pads does not.)
            let swing =
                (v3("object_linear_velocity")? - vector_at(observation, &s.tcp_velocity)).norm();
            if off_goal < p.arrival_distance && swing > SETTLED_SWING && aloft {
                let wait = Vector3::new(goal.x + offset.x, goal.y + offset.y, tcp.z);
                return Ok(decision(Phase::SETTLE, wait, 0.3, p.arrival_gain, -1.0));
            }
            let carry_z = (platform_top + CARRY_CLEARANCE + half.z).max(goal.z);
            // An object hanging far from the fingers (a bottle by its neck, a bowl by its
            // rim) swings out of a pinch when the hand accelerates hard: carry it slower.
            // One whose centre is off to the side of the fingers (a bowl by its rim) turns in
            // the pinch under its own weight as well: slower still.
            let lever = (grasp - centre).norm();
            let side_lever = (grasp - centre).xy().norm();
            let carry_speed = (SWING_LEVER / lever.max(1e-3))
                .min(SIDE_LEVER / side_lever.max(1e-3))
                .clamp(MIN_CARRY_SPEED, 1.0);
            if off_goal > p.place_tolerance {
                let (phase, target) = if off_goal < p.arrival_distance {
                    // Close over the goal: come down along a funnel while lining up.
                    let z = (goal.z + 2.0 * off_goal).min(centre.z).max(goal.z);
                    (Phase::LOWER, Vector3::new(goal.x, goal.y, z))
                } else if bottom > platform_top + 0.5 * CARRY_CLEARANCE {
                    (Phase::CARRY, Vector3::new(goal.x, goal.y, carry_z))
                } else {
                    (
                        Phase::LIFT,
                        Vector3::new(centre.x, centre.y, carry_z + 0.01),
                    )
                };
                let gain = if phase == Phase::LOWER {
                    p.arrival_gain
                } else {
                    1.0
                };
                return Ok(decision(phase, target + offset, carry_speed, gain, -1.0));
            }
            let hand_floor = surface.max(platform_top) + config.ee_surface_clearance;
            let hand_lowest = config.control_mode != panda_rapier_core::env::ControlMode::Joints
                && tcp.z < hand_floor + 0.003;
            // Set down: the centre at its resting height, or the lowest corner of the
            // object's box on the surface (an object tilted in the hand lands before its
            // centre gets there).
            let above = (centre.z - goal.z).min(lowest - platform_top);
            if above > p.release_height && !hand_lowest {
                return Ok(decision(
                    Phase::LOWER,
                    goal + offset,
                    1.0,
                    p.arrival_gain,
                    -1.0,
                ));
            }
            // Landed tilted (swung in a pinch): press on gently, which turns it about the
            // fingers onto its base, before letting go; let go tilted, a tall object topples.
            // (Pressed onto its base, its centre is down at its resting height: a lying object
            // turned in the pads about its long side is not lifted by that, and pressing it
            // would only push the hand into the platform.)
            if tilted_up && !hand_lowest {
                let down = goal + offset - Vector3::new(0.0, 0.0, MAX_PRESS);
                return Ok(decision(
                    Phase::LOWER,
                    down,
                    PRESS_SPEED,
                    p.arrival_gain,
                    -1.0,
                ));
            }
            // Set down still moving in the hand (landing), it is held where it is until it
            // stops: let go moving, a round one rolls away.
            if swing > LANDED_SPEED {
                return Ok(decision(Phase::SETTLE, tcp, 0.0, 1.0, -1.0));
            }
            return Ok(decision(Phase::RELEASE, unjammed, UNJAM_SPEED, 1.0, 1.0));
        }
        let resting = (centre.z - goal.z).abs() < 0.01;
        if (centre - goal).norm() < config.success_threshold && resting {
            // Placed (or being let go): open, then back off upwards.
            if hand_closed && around {
                return Ok(decision(Phase::RELEASE, unjammed, UNJAM_SPEED, 1.0, 1.0));
            }
            // Straight up, slowly until the fingertips clear the object's top.
            let up = Vector3::new(tcp.x, tcp.y, goal.z + half.z + p.retreat_height);
            let clear = tcp.z - FINGERTIPS > centre.z + half.z + 0.01;
            let speed = if clear { 1.0 } else { RETREAT_SPEED };
            return Ok(decision(Phase::RETREAT, up, speed, 1.0, 1.0));
        }
        let sideways = to_grasp.xy().norm();
        let at_grasp = sideways < AT_GRASP_SIDEWAYS && to_grasp.z.abs() < AT_GRASP_HEIGHT;
        if around && (hand_closed || (at_grasp && tcp_speed < p.settle_speed)) {
            // Squeeze with the hand held still: first close to just wider than the grasp, then
            // squeeze from there (fingers slammed shut from wide open pass through a rim or a
            // neck before the contacts stop them).
            let gripper = if width > grasp_width + PRE_CLOSE_GAP && !(hand_closed && blocked) {
                (grasp_width / (cx.open_width / 2.0) - 1.0) as f32
            } else {
                -1.0
            };
            return Ok(decision(Phase::CLOSE, tcp, 0.0, 1.0, gripper));
        }
        if hand_closed {
            // A closed hand away from the grasp (missed or lost): open it, rising above the
            // object while it opens.
            let top = centre.z + half.z;
            let up = Vector3::new(tcp.x, tcp.y, tcp.z.max(top + OVER_TOP));
            return Ok(decision(Phase::APPROACH, up, 1.0, 1.0, 1.0));
        }
        // Come in over the object with the fingertips clear of its top, turn to the grasp,
        // then straight down.
        let top = centre.z + half.z;
        let over = top + OVER_TOP + FINGERTIPS;
        if sideways <= LINED_UP && yaw_error < TURNED {
            // Slower over the last centimetres: the fingers land within millimetres of the
            // object's other parts.
            let speed = if to_grasp.z.abs() < 0.03 {
                0.5 * DESCEND_SPEED
            } else {
                DESCEND_SPEED
            };
            return Ok(decision(
                Phase::DESCEND,
                grasp_at,
                speed,
                p.arrival_gain,
                1.0,
            ));
        }
        if around {
            // The open hand is down around the object but off its grasp (it moved, or was just
            // let go): first straight up, slowly (moving sideways, or fast, the fingers drag
            // it along).
            let up = Vector3::new(tcp.x, tcp.y, over.max(grasp_at.z));
            return Ok(decision(Phase::APPROACH, up, RETREAT_SPEED, 1.0, 1.0));
        }
        let height = if sideways < 2.5 * LINED_UP {
            // Nearly lined up: hold the height while the hand centres and turns.
            tcp.z.clamp(grasp_at.z, over.max(grasp_at.z))
        } else {
            over.max(grasp_at.z)
        };
        let above = Vector3::new(grasp_at.x, grasp_at.y, height);
        Ok(decision(Phase::APPROACH, above, 1.0, 1.0, 1.0))
    }
}
