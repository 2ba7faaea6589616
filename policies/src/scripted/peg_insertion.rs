//! [`PegInsertionExpert`]: picks the peg up across its width at a point a little more than the
//! hole's depth behind the end that will lead, turns the hand so the peg lies along the hole's
//! axis, brings the leading end in front of the opening at the hole's height, and pushes it in
//! to the bottom. Like every expert it is stateless: each step it reads where the peg, its ends
//! and the hole are, and steers the peg's actual leading end (not the hand) onto its target, so
//! a peg that turned or slid in the fingers is corrected on the way.
//!
//! The hand turns only in `ee_pose` and `joints` control (the task's ids); in `ee` control it
//! stays at `hand_down`, and the expert succeeds only with pegs and holes lying near that yaw.

use nalgebra::{UnitQuaternion, Vector3};
use panda_rapier_core::task::flip::quaternion;
use panda_rapier_core::{Error, Result};

use super::{vector_at, wrap_half_turn, Decision, Expert, ExpertContext, Phase};

impl Phase {
    /// Lifting the held peg clear of the platform and the box.
    pub const RAISE: Phase = Phase::new("raise");
    /// Turning and carrying the held peg to the front of the opening, above it.
    pub const TRANSFER: Phase = Phase::new("transfer");
    /// Lowering the peg to the hole's height in front of the opening, lined up with its axis
    /// (a flip expert's `line_up` is also a lining up, before a push).
    /// Pushing the lined-up peg into the hole.
    pub const INSERT: Phase = Phase::new("insert");
}

/// The scripted expert of `peg_insertion` (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct PegInsertionExpert;

/// How far (m) behind the hole's depth the fingers hold the peg: they stay out of the opening.
const GRIP_BEHIND_DEPTH: f64 = 0.025;
/// The fingers keep at least this far (m) from the peg's trailing end.
const GRIP_END_MARGIN: f64 = 0.012;
/// Where the leading end waits before going in: this far (m) in front of the opening.
const STANDOFF: f64 = 0.03;
/// Height (m) of the peg's centre above the hole's centre while it is carried over.
const CARRY_HEIGHT: f64 = 0.06;
/// The leading end counts as lined up within this distance (m) of its waiting point...
const LINED_UP: f64 = 0.002;
/// The sideways error of the leading end is asked for this many times over.
const SIDEWAYS_GAIN: f64 = 1.0;
/// ...and its vertical error this many times more: the arm's joints settle lower than asked
/// (their PD motors hold it against gravity), leaving the leading end a few millimetres low.
const SAG_GAIN: f64 = 2.0;
/// Fraction of the remaining error covered per step while inserting.
const INSERT_GAIN: f64 = 0.7;
/// The leading end is steered along the axis line within this distance (m) of it.
const CORRIDOR: f64 = 0.012;
/// ...and the peg within this yaw (rad) of the hole's axis.
const TURNED: f64 = 0.02;
/// Largest turn (rad) about the closing axis asked for in one step to level the peg...
const MAX_PITCH_STEP: f64 = 0.2;
/// ...and the fraction of the peg's tilt asked for...
const PITCH_GAIN: f64 = 0.5;
/// ...and the most (rad) the hand tilts from pointing down to level it.
const MAX_TILT: f64 = 0.12;
/// Speed (fraction of a full action) of the push into the hole.
const INSERT_SPEED: f64 = 0.12;

/// The yaw (rad) of the horizontal part of `v`.
fn yaw(v: &Vector3<f64>) -> f64 {
    v.y.atan2(v.x)
}

impl Expert for PegInsertionExpert {
    fn decide(&self, cx: &ExpertContext, observation: &[f32]) -> Result<Decision> {
        let slot = |name: &str| {
            cx.slot(name).ok_or_else(|| Error::InvalidConfig {
                field: "task".into(),
                reason: format!("the peg insertion expert needs the `{name}` observation slot"),
            })
        };
        let v3 = |name: &str| slot(name).map(|r| vector_at(observation, &r));
        let quat = |name: &str| slot(name).map(|r| quaternion(&observation[r]));
        let s = &cx.slots;
        let p = &cx.params;
        let tcp = vector_at(observation, &s.tcp);
        let width = observation[s.width] as f64;
        let peg = v3("peg_position")?;
        let peg_rotation = quat("peg_orientation")?;
        let half = v3("peg_half_extents")?;
        let opening = v3("hole_position")?;
        let hole_rotation = quat("hole_orientation")?;
        let hand = quat("tcp_orientation")?;
        let hole_half_width = slot("hole_half_width").map(|r| observation[r.start] as f64)?;
        let bottom = vector_at(observation, &s.desired);
        let ee_step = cx.config().ee_step;

        // Which end leads: the one facing the hole (the hand turns the peg by less than a
        // quarter turn, so it stays the one).
        let axis = hole_rotation * Vector3::x();
        let along = peg_rotation * Vector3::x();
        let lead_dir = if along.dot(&axis) >= 0.0 {
            along
        } else {
            -along
        };
        let lead = peg + lead_dir * half.x;
        let depth = (bottom - opening).dot(&axis);
        let grip_from_lead = (depth + GRIP_BEHIND_DEPTH).min(2.0 * half.x - GRIP_END_MARGIN);
        let grip = lead - lead_dir * grip_from_lead;

        // The hand's yaw from `hand_down` now, and the yaws it takes: across the peg to pick
        // it up, the peg along the hole's axis to insert it. The closing axis is the hand's
        // y axis.
        let closing_down = cx.hand_down * Vector3::y();
        let closing_now = hand * Vector3::y();
        let hand_yaw = wrap_full(yaw(&closing_now) - yaw(&closing_down));
        // The hand's yaw with the peg along the axis: its closing axis across the axis, the
        // one of the two nearer `hand_down`.
        let insert_yaw =
            wrap_half_turn(yaw(&axis) + std::f64::consts::FRAC_PI_2 - yaw(&closing_down));
        // Picking up, it is turned back by the angle the peg lies off the axis, so that
        // turning the held peg onto the axis brings the hand to `insert_yaw`.
        let off_axis = wrap_half_turn(yaw(&axis) - yaw(&lead_dir));
        let pick_yaw = insert_yaw - off_axis;

        let decision = |phase, tcp_target, speed, gain, gripper, hand| Decision {
            phase,
            tcp_target,
            speed,
            gain,
            gripper,
            hand: Some(hand),
        };
        // The hand pointing down, turned by `yaw` from `hand_down`.
        let down =
            |yaw: f64| UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw) * cx.hand_down;

        // In the hand: the TCP within the peg's width of its axis and level with it, near the
        // grip point, the fingers squeezing something about the peg's width.
        let to_peg = peg - tcp;
        let across = (to_peg - along * to_peg.dot(&along)).norm();
        let around = across < half.y + 0.01 && (grip - tcp).norm() < 0.04;
        let squeezing = width < 0.9 * cx.open_width && width > 1.2 * half.y;
        if around && squeezing {
            // The turn that lays the peg along the axis: about the vertical by what its yaw is
            // off, and about the fingers' closing axis by what its leading end droops (or
            // rises), applied to the hand as it is now.
            let turn_left = wrap_half_turn(yaw(&axis) - yaw(&lead_dir));
            let closing = closing_now;
            let lever = closing.cross(&lead_dir).z;
            let droop = if lever.abs() > 0.3 {
                (-lead_dir.z / lever).clamp(-MAX_PITCH_STEP, MAX_PITCH_STEP)
            } else {
                0.0
            };
            // Where the ends are: how far the leading one is in, and how far each is off the
            // axis line.
            let off_line = |p: Vector3<f64>| {
                let d = bottom - p;
                d - axis * d.dot(&axis)
            };
            let tail = lead - lead_dir * (2.0 * half.x);
            let inside = (lead - opening).dot(&axis);
            let lead_off = off_line(lead);
            let tail_off = off_line(tail);
            // In the hole: past the opening and within the hole's width of its axis line (a
            // peg still on the floor may lie "past" the opening's plane, far from it).
            let in_hole = inside > 0.003 && lead_off.norm() < hole_half_width;
            // In the hole the walls line the peg up; the hand only follows, gently.
            let (turn, pitch) = if in_hole {
                (turn_left.clamp(-0.02, 0.02), 0.0)
            } else {
                (0.6 * turn_left, PITCH_GAIN * droop)
            };
            // The hand's tilt about the closing axis now, and the tilt it may reach: a peg
            // propped on an edge does not level however the hand turns, and the turn must not
            // run away.
            let tilt_now = (-(hand * Vector3::z()).dot(&closing.cross(&Vector3::z())))
                .clamp(-1.0, 1.0)
                .asin();
            let tilt = (tilt_now + pitch).clamp(-MAX_TILT, MAX_TILT);
            // Built from `hand_down` (not from the hand as it is), so that no roll about the
            // peg's axis, which nothing measured would correct, creeps in.
            let yaw_target = hand_yaw + turn;
            let down_turned = down(yaw_target);
            let turned_hand =
                UnitQuaternion::from_scaled_axis((down_turned * Vector3::y()) * tilt) * down_turned;
            let standoff = opening - axis * STANDOFF;
            // In the corridor in front of the opening (or already in): servo the leading end
            // onto the axis line every step, and move it along the line only while it is on
            // it: forward while the ends are on the line, back a little when it sits against
            // the face beside the opening, and otherwise hold the depth while the hand
            // corrects sideways (so small errors never send the peg back up).
            let in_corridor = inside > -(STANDOFF + 0.01)
                && lead_off.norm() < CORRIDOR
                && turn_left.abs() < 3.0 * TURNED;
            if in_hole || in_corridor {
                let on_line = lead_off.norm() < 1.25 * LINED_UP && tail_off.norm() < 3.0 * LINED_UP;
                let clearance = hole_half_width - half.y;
                let against_face = inside > -0.003 && lead_off.norm() > clearance;
                let advance = if in_hole || on_line {
                    INSERT_SPEED * ee_step
                } else if against_face {
                    -0.003
                } else {
                    0.0
                };
                // Once in, the walls hold the leading end; the hand lines up the trailing end.
                // The arm settles a millimetre or two short of each target (the joints' PD
                // motors against gravity): asking for more than the error cancels most of it.
                let sideways = if in_hole {
                    0.5 * tail_off
                } else {
                    let mut s = SIDEWAYS_GAIN * lead_off;
                    s.z *= SAG_GAIN;
                    s
                };
                let depth_left = (bottom - lead).dot(&axis);
                let step = axis * advance.min(depth_left) + sideways;
                return Ok(decision(
                    Phase::INSERT,
                    tcp + straight(step, 1.0, INSERT_GAIN, ee_step),
                    1.0,
                    INSERT_GAIN,
                    -1.0,
                    turned_hand,
                ));
            }
            let tcp_speed = vector_at(observation, &s.tcp_velocity).norm();
            let over = (standoff - lead).xy().norm();
            if over < 0.01 && turn_left.abs() < 2.0 * TURNED && tcp_speed < p.settle_speed {
                // Over the waiting point, turned and steady: come down to it.
                return Ok(decision(
                    Phase::LINE_UP,
                    tcp + straight(standoff - lead, 0.5, p.arrival_gain, ee_step),
                    1.0,
                    p.arrival_gain,
                    -1.0,
                    turned_hand,
                ));
            }
            let carry_z = opening.z + CARRY_HEIGHT;
            if peg.z < carry_z - 0.02 && over > 0.03 {
                // Up first, straight, clear of the platform's edge and the box.
                let up = Vector3::new(tcp.x, tcp.y, tcp.z + (carry_z - peg.z));
                return Ok(decision(Phase::RAISE, up, 1.0, 1.0, -1.0, turned_hand));
            }
            // Over to the waiting point, at the carrying height (or where the peg is now, if
            // it is already lower, over the waiting point), slowing down on arrival.
            let z = if over < 0.03 {
                lead.z.min(carry_z)
            } else {
                carry_z
            };
            let above = Vector3::new(standoff.x, standoff.y, z);
            let gain = if over < 0.05 { p.arrival_gain } else { 1.0 };
            return Ok(decision(
                Phase::TRANSFER,
                tcp + straight(above - lead, 1.0, gain, ee_step),
                1.0,
                gain,
                -1.0,
                turned_hand,
            ));
        }

        // Not in the hand: pick it up at the grip point, across its width. Sideways errors
        // across the peg matter (a finger lands on it); along it they do not.
        let hand_closed = width < 0.9 * cx.open_width;
        let offset = (grip - tcp).xy();
        let along_xy = Vector3::new(along.x, along.y, 0.0)
            .try_normalize(1e-9)
            .unwrap_or_else(Vector3::x)
            .xy();
        let off_along = offset.dot(&along_xy).abs();
        let off_across = (offset - along_xy * offset.dot(&along_xy)).norm();
        let misalignment = off_across.max(off_along / 3.0);
        let turned = (hand_yaw - pick_yaw).abs() < 0.05;
        let low = tcp.z - grip.z < 0.012;
        let settled = vector_at(observation, &s.tcp_velocity).norm() < p.settle_speed;
        if off_across < 0.008 && off_along < 0.02 && low && (hand_closed || settled) {
            return Ok(decision(Phase::CLOSE, tcp, 0.0, 1.0, -1.0, down(pick_yaw)));
        }
        if hand_closed {
            // A missed or lost grasp: open while rising.
            let up = Vector3::new(tcp.x, tcp.y, tcp.z.max(peg.z + p.hover_height));
            return Ok(decision(Phase::APPROACH, up, 1.0, 1.0, 1.0, down(pick_yaw)));
        }
        if misalignment <= p.align_tolerance && turned {
            return Ok(decision(
                Phase::DESCEND,
                grip,
                1.0,
                p.arrival_gain,
                1.0,
                down(pick_yaw),
            ));
        }
        // Come in along a funnel over the grip point, holding the height once nearly lined up
        // (rather than bouncing up after every small sideways wobble).
        let mut height = (0.045 + 0.5 * (misalignment - p.align_tolerance)).min(p.hover_height);
        if misalignment < 2.5 * p.align_tolerance && tcp.z > grip.z + p.in_hand_height {
            height = height.min(tcp.z - grip.z);
        }
        let above = Vector3::new(grip.x, grip.y, grip.z + height);
        Ok(decision(
            Phase::APPROACH,
            above,
            1.0,
            1.0,
            1.0,
            down(pick_yaw),
        ))
    }
}

/// `step` shortened, keeping its direction, so that no axis of the action it becomes (each
/// `gain * step / ee_step`) exceeds `speed`: the policy clips each axis on its own, which would
/// bend a path that must stay on a line.
fn straight(step: Vector3<f64>, speed: f64, gain: f64, ee_step: f64) -> Vector3<f64> {
    let largest = step.amax() * gain / ee_step;
    if largest > speed {
        step * (speed / largest)
    } else {
        step
    }
}

/// The angle `a` wrapped into `(-pi, pi]`.
fn wrap_full(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let mut a = a.rem_euclid(TAU);
    if a > PI {
        a -= TAU;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_turn_wrapping_keeps_directions() {
        use std::f64::consts::PI;
        for (a, w) in [
            (0.3, 0.3),
            (PI - 0.2, -0.2),
            (-PI + 0.1, 0.1),
            (PI / 2.0, PI / 2.0),
        ] {
            assert!((wrap_half_turn(a) - w).abs() < 1e-12, "{a}");
        }
        assert!((wrap_full(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
    }
}
