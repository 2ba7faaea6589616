//! The `push` task's expert: the hand, closed, goes behind the cube on the line from the goal
//! through the cube, comes down to the cube's lower half and pushes along that line, backing
//! off to line up again whenever the cube drifts off it; it rises off the cube once the cube
//! is at the goal. The line is recomputed from every observation, so a cube that turns or
//! slides sideways only changes where "behind" is.

use nalgebra::{UnitQuaternion, Vector3};
use panda_rapier_core::{ArmFidelity, Result};

use super::{vector_at, Decision, Expert, ExpertContext, Phase};

impl Phase {
    /// Moving the closed hand behind the cube, on its far side from the goal.
    pub const ALIGN: Phase = Phase::new("align");
    /// Pushing the cube along the floor towards the goal.
    pub const PUSH: Phase = Phase::new("push");
}

/// The `push` task's expert (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct PushExpert;

impl Expert for PushExpert {
    fn decide(&self, cx: &ExpertContext, observation: &[f32]) -> Result<Decision> {
        let s = &cx.slots;
        let cube = vector_at(observation, &s.achieved);
        let goal = vector_at(observation, &s.desired);
        let tcp = vector_at(observation, &s.tcp);
        let width = observation[s.width] as f64;
        Ok(decide(cx, observation, cube, goal, tcp, width))
    }
}

fn decide(
    cx: &ExpertContext,
    observation: &[f32],
    cube: Vector3<f64>,
    goal: Vector3<f64>,
    tcp: Vector3<f64>,
    width: f64,
) -> Decision {
    let p = &cx.params;
    let h = cx.cube_half;
    let to_goal = (goal - cube).xy();
    let distance = to_goal.norm();
    let decision = |phase, tcp_target, speed, gain| Decision {
        hand: None,
        phase,
        tcp_target,
        speed,
        gain,
        gripper: -1.0,
    };
    // High enough that the fingertips (8 mm below the TCP) pass over the cube.
    let over = cube.z + h + p.push_clearance;
    if distance < p.push_done {
        // At the goal: rise straight up, off the cube.
        let up = Vector3::new(tcp.x, tcp.y, tcp.z.max(over));
        return decision(Phase::RETREAT, up, 0.5, 1.0);
    }
    let u = to_goal / distance;
    let n = nalgebra::Vector2::new(-u.y, u.x);
    // How far the cube reaches from its centre along the push direction (its support in
    // that direction, whatever its orientation: it may have turned or tipped over).
    let mut upright = 1.0;
    let extent = match &cx.slots.cube_orientation {
        Some(slot) => {
            let q = &observation[slot.start..slot.start + 4];
            let rotation = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                q[3] as f64,
                q[0] as f64,
                q[1] as f64,
                q[2] as f64,
            ))
            .to_rotation_matrix();
            let m = rotation.matrix();
            upright = (0..3).map(|i| m[(2, i)].abs()).fold(0.0, f64::max);
            (0..3)
                .map(|i| (m[(0, i)] * u.x + m[(1, i)] * u.y).abs())
                .sum::<f64>()
                * h
        }
        None => h,
    };
    let relative = (tcp - cube).xy();
    let along = relative.dot(&u);
    let across = relative.dot(&n);
    let floor = cx.config.surface_height(tcp.x, tcp.y) + cx.config.ee_surface_clearance;
    let push_z = (cube.z + p.push_height).max(floor);
    let closed = width < p.push_closed_width;
    let low = tcp.z < over - 0.01;
    // Fully behind the cube's back face: free to move sideways at pushing height.
    let behind = along < -(extent + p.pusher_half_width);
    let behind_point = cube.xy() - u * (extent + p.pusher_half_width + p.push_gap);
    let at = |xy: nalgebra::Vector2<f64>, z: f64| Vector3::new(xy.x, xy.y, z);
    let at_height = tcp.z < push_z + p.push_height_tolerance;
    // The cube tilting, or pressed into the floor: the fingers are riding onto it (it
    // would wedge itself and stop). Let go upwards; it settles, and the approach starts
    // over.
    let jammed = upright < p.push_upright.cos() || cube.z < h - p.push_sink;
    if jammed && low {
        let up = Vector3::new(tcp.x, tcp.y, over + 0.01);
        return decision(Phase::ALIGN, up, 1.0, 1.0);
    }
    if closed && at_height && along < -0.5 * extent && across.abs() < p.push_line_tolerance {
        // On the line behind the cube: push, steering back onto the line, slowing down
        // as the cube nears the goal.
        let advance = (p.push_speed * cx.config.ee_step).min(distance);
        let target = cube.xy() + u * (along + advance);
        let gain = if distance < p.arrival_distance {
            p.arrival_gain
        } else {
            1.0
        };
        // The pushing arm sags under the contact (the dynamic arm by several millimetres):
        // aim above the pushing height by the shortfall, as a proportional correction.
        let sag = (push_z - tcp.z).clamp(0.0, p.push_sag_limit);
        let z = push_z + p.push_sag_gain * sag / gain;
        return decision(Phase::PUSH, at(target, z), 1.0, gain);
    }
    // Behind the cube (or just short of its back face, straight behind it) but off the
    // line or not down yet: line up at pushing height before touching the cube (coming
    // down on it tips it over). Still touching it: straight back first (moved sideways,
    // the fingers would drag it along and tip it).
    if closed && low && (behind || (along < -extent && across.abs() < extent)) {
        let touching = along > -(extent + p.pusher_half_width + 0.5 * p.push_gap);
        let target = if touching {
            tcp.xy() - u * p.push_gap
        } else {
            behind_point
        };
        return decision(Phase::ALIGN, at(target, push_z), 1.0, p.arrival_gain);
    }
    if low && !behind {
        // Beside or in front of the cube: up before anything else.
        let up = Vector3::new(tcp.x, tcp.y, over + 0.01);
        let target = if tcp.z > over - 0.02 {
            at(behind_point, over + 0.01)
        } else {
            up
        };
        return decision(Phase::ALIGN, target, 1.0, 1.0);
    }
    // Above: fly to the point behind the cube, coming down along a funnel once behind its
    // back face (descending there cannot land on the cube), but not before the hand has
    // closed.
    let off = (tcp.xy() - behind_point).norm();
    // The last stretch down is taken in halves: the arm carries momentum, and a hand
    // overshooting into the floor next to the cube knocks it over.
    let down = push_z + off.max(p.arrival_gain * (tcp.z - push_z));
    let mut z = if behind { down } else { over + 0.01 };
    if !closed {
        z = z.max(over + 0.01);
    }
    // Slow down for the last few centimetres: the dynamic arm overshoots downwards
    // otherwise (the kinematic one follows its targets).
    let dynamic = cx.config.arm == ArmFidelity::Dynamic;
    let speed = if dynamic && behind && tcp.z < over + p.push_descent_height {
        p.push_descent_speed
    } else {
        1.0
    };
    decision(
        Phase::ALIGN,
        at(behind_point, z.min(tcp.z.max(over + 0.01))),
        speed,
        1.0,
    )
}
