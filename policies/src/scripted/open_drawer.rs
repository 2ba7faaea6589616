//! [`OpenDrawerExpert`]: turns the hand so its fingers close across the knob's stem, comes
//! down over the stem with the fingers open, closes them on it and pulls along the drawer's
//! way out until the drawer is open a little past the goal, then holds. Stateless like every
//! expert: each step it reads where the knob, the hand and the drawer are; a hand that lost
//! the knob (it is no longer between the closed fingers) goes back over it.

use nalgebra::{UnitQuaternion, Vector3};
use panda_rapier_core::task::flip::quaternion;
use panda_rapier_core::{Error, Result};

use super::{vector_at, wrap_half_turn, Decision, Expert, ExpertContext, Phase};

impl Phase {
    /// Turning the hand and moving it above the knob.
    pub const OVER_KNOB: Phase = Phase::new("over_knob");
    /// Coming down around the knob's stem, fingers open.
    pub const DOWN_TO_KNOB: Phase = Phase::new("down_to_knob");
    /// Closing the fingers on the stem.
    pub const CLOSE_ON_KNOB: Phase = Phase::new("close_on_knob");
    /// Pulling the drawer out.
    pub const PULL: Phase = Phase::new("pull");
    /// Holding the opened drawer (the grasp sequence's `hold` holds a cube in place).
    pub const HOLD_OPEN: Phase = Phase::new("hold_open");
}

/// The scripted expert of `open_drawer` (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct OpenDrawerExpert;

/// Height (m) above the stem the hand comes to before going down.
const HOVER: f64 = 0.06;
/// The hand goes down once it is this close (m) to above the stem, horizontally...
const OVER: f64 = 0.008;
/// ...and turned to within this (rad) of the stem's crossing yaw.
const TURNED: f64 = 0.05;
/// The fingers close once the TCP is this close (m) to the grasp point.
const AT_KNOB: f64 = 0.008;
/// The knob counts as held with the TCP this close (m) to the grasp point and the pads closed
/// to at most `HELD_WIDTH` (m) (the stem is 2 cm across).
const HELD_REACH: f64 = 0.025;
const HELD_WIDTH: f64 = 0.03;
/// The drawer is pulled this far (m) past the goal opening.
const OVERSHOOT: f64 = 0.015;
/// Speed (fraction of a full action) of the pull and of the way down.
const PULL_SPEED: f64 = 0.6;
const DOWN_SPEED: f64 = 0.5;

/// The yaw (rad) of the horizontal part of `v`.
fn yaw(v: &Vector3<f64>) -> f64 {
    v.y.atan2(v.x)
}

impl Expert for OpenDrawerExpert {
    fn decide(&self, cx: &ExpertContext, observation: &[f32]) -> Result<Decision> {
        let slot = |name: &str| {
            cx.slot(name).ok_or_else(|| Error::InvalidConfig {
                field: "task".into(),
                reason: format!("the drawer expert needs the `{name}` observation slot"),
            })
        };
        let s = &cx.slots;
        let p = &cx.params;
        let tcp = vector_at(observation, &s.tcp);
        let width = observation[s.width] as f64;
        let knob = vector_at(observation, &slot("handle_position")?);
        let out = vector_at(observation, &slot("opening_direction")?);
        let hand = quaternion(&observation[slot("tcp_orientation")?]);
        let opening = observation[s.achieved.start] as f64;
        let goal = observation[s.desired.start] as f64;

        // The fingers close along the hand's y axis: across the stem, which runs along `out`.
        let closing_down = cx.hand_down * Vector3::y();
        let across = Vector3::z().cross(&out);
        let target_yaw = wrap_half_turn(yaw(&across) - yaw(&closing_down));
        let hand_yaw = yaw(&(hand * Vector3::y())) - yaw(&closing_down);
        let turned = wrap_half_turn(hand_yaw - target_yaw).abs() < TURNED;
        let down = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), target_yaw) * cx.hand_down;
        let decision = |phase, tcp_target, speed, gain, gripper| Decision {
            phase,
            tcp_target,
            speed,
            gain,
            gripper,
            hand: Some(down),
        };

        let to_knob = knob - tcp;
        let held = to_knob.norm() < HELD_REACH && width < HELD_WIDTH;
        if held {
            let left = goal + OVERSHOOT - opening;
            if left <= 0.0 {
                return Ok(decision(Phase::HOLD_OPEN, tcp, 1.0, 1.0, -1.0));
            }
            // The hand follows the knob out, the TCP kept on it.
            let target = knob + out * left;
            return Ok(decision(Phase::PULL, target, PULL_SPEED, 1.0, -1.0));
        }
        let horizontal = Vector3::new(to_knob.x, to_knob.y, 0.0).norm();
        if to_knob.norm() < AT_KNOB {
            return Ok(decision(Phase::CLOSE_ON_KNOB, knob, 1.0, 1.0, -1.0));
        }
        if horizontal < OVER && turned && width > HELD_WIDTH {
            return Ok(decision(
                Phase::DOWN_TO_KNOB,
                knob,
                DOWN_SPEED,
                p.arrival_gain,
                1.0,
            ));
        }
        // Above the stem first; a hand below the hover height that is off to the side rises
        // straight up before it moves over.
        let hover = knob + Vector3::z() * HOVER;
        let target = if tcp.z < knob.z + 0.5 * HOVER && horizontal > 2.0 * OVER {
            Vector3::new(tcp.x, tcp.y, hover.z)
        } else {
            hover
        };
        Ok(decision(Phase::OVER_KNOB, target, 1.0, p.arrival_gain, 1.0))
    }
}
