//! The `flip` task's expert: the hand keeps pointing down (in `ee` control it cannot turn), so
//! the cube is turned by pushing it with the closed fingers.
//!
//! - **Roll**: the fingers press on a side face above its middle and go round the cube's far
//!   bottom edge with that face, a little ahead of its tilt, until the cube topples over the
//!   edge: a quarter turn. Pushed straight ahead instead, the face rises against the fingers,
//!   whose friction holds it down, and the cube slides rather than tips (measured: 0 of 100
//!   single rolls at a slow push, 50-90 % struck fast; 97-100 % going round).
//! - **Spin**: the fingers push a side face at its end, level with the cube's middle; the cube
//!   turns about the vertical (and drifts).
//!
//! From every observation of the cube resting flat, the expert plans the cheapest way to the
//! goal: a sequence of up to four rolls, each towards one of the four side faces, after which
//! the cube is within the threshold (less a margin), or failing that one followed by a spin;
//! it starts the plan's first move, the hand first lining up behind the face. Plans that tie
//! are told apart by how near the hand is to each first move, so rounding cannot switch the
//! hand between them. A roll under way (the cube tilted) is followed round until the cube
//! topples, then left to fall and settle.
//!
//! Rolls alone reach the 24 ways a cube can rest; about 87 % of uniformly random goals lie
//! within panda-gym's threshold of one of them, and rolls and a final spin reach all but about
//! 1 % (`plans_carried_out_exactly_reach_almost_every_goal`). Spins are the less reliable
//! move: over 1,000 seeded episodes (`examples/flip_diagnose`), episodes without one succeed
//! in 98.8 %, the fifth with one in 92 %.

use nalgebra::{Quaternion, UnitQuaternion, Vector2, Vector3};
use panda_rapier_core::task::flip::{angle_between as angle, quaternion};
use panda_rapier_core::task::TaskConfig;
use panda_rapier_core::Result;

use super::{vector_at, Decision, Expert, ExpertContext, Phase};

impl Phase {
    /// `flip`: the hand goes behind the face the next move pushes.
    pub const LINE_UP: Phase = Phase::new("line_up");
    /// `flip`: going round the cube's far bottom edge with a side face: it tips over.
    pub const ROLL: Phase = Phase::new("roll");
    /// `flip`: pushing a side face at its end: it turns about the vertical.
    pub const SPIN: Phase = Phase::new("spin");
    /// `flip`: the hand stays clear while the cube falls or settles.
    pub const SETTLE: Phase = Phase::new("settle");
    /// `flip`: the cube is turned to the goal; the hand stays clear above it.
    pub const DONE: Phase = Phase::new("done");
}

/// Longest plan of rolls searched.
const MAX_ROLLS: usize = 4;
/// A plan must leave the cube this much (rad) inside the threshold...
const MARGIN: f64 = 0.2;
/// ...and the cube counts as turned once it is this much inside.
const DONE_MARGIN: f64 = 0.01;
/// Plans ending within this (rad) of the nearest any plan reaches count as reaching it.
const NEAREST_TOLERANCE: f64 = 0.02;
/// Plans within this cost of the cheapest tie with it.
const TIE: f64 = 0.05;
/// A spin costs as much as this many rolls, plus `SPIN_COST_PER_RAD` per radian turned.
const SPIN_COST: f64 = 1.5;
/// See `SPIN_COST`.
const SPIN_COST_PER_RAD: f64 = 2.0;
/// The cube rests flat while its up axis is within this (rad) of the vertical.
const FLAT_TILT: f64 = 0.06;
/// A cube tilted more than this (rad) falls over by itself: the hand backs off.
const TOPPLE_TILT: f64 = 0.75;
/// The cube counts as at rest below these speeds (m/s, rad/s).
const REST_SPEED: f64 = 0.02;
/// See `REST_SPEED`.
const REST_SPIN: f64 = 0.3;
/// Height (m) of the TCP above the cube's centre where a roll starts (the pads on the face's
/// upper half; measured 97-100 % of single rolls from 0 to 0.018).
const ROLL_HEIGHT: f64 = 0.01;
/// How far ahead of the cube's tilt (rad) the fingers going round with a roll are sent.
const ROLL_STEP: f64 = 0.2;
/// The fingers follow a roll while within this distance (m) of where the tilt puts them.
const ROLL_TRACK: f64 = 0.02;
/// A spin's choice of face leans towards driving the cube to the middle of its region by up
/// to this much (m) of the hand's way to it.
const SPIN_INWARD_BIAS: f64 = 0.05;
/// Height (m) of the TCP above the cube's centre while spinning it (lower or higher tipped the
/// cube more often).
const SPIN_HEIGHT: f64 = 0.008;
/// Where along the face (a fraction of the half edge from the centre) the centre of the
/// fingers pushes: at its end, so they meet the face over half their width (measured better
/// than 0.7, on a par with 0.9-1.3).
const SPIN_OFFSET: f64 = 1.0;
/// Half the width (m) of the closed fingers, seen from the cube.
const PUSHER_HALF_WIDTH: f64 = 0.012;
/// Gap (m) between the fingers and the face when lining up.
const GAP: f64 = 0.015;
/// Height (m) of the fingertips over the cube's top when passing over it.
const CLEARANCE: f64 = 0.04;
/// The hand pushes once within this (m) of the line-up point, sideways and in height.
const LINE_TOLERANCE: f64 = 0.008;
/// Spinning speed (a fraction of a full action; 0.15 and 0.8 did worse).
const SPIN_SPEED: f64 = 0.45;
/// The largest sag (m) of the pushing hand corrected.
const SAG_LIMIT: f64 = 0.01;
/// Below this height (m) above the pushing height, the hand comes down...
const DESCENT_HEIGHT: f64 = 0.1;
/// ...at this speed (a fraction of a full action); all the way down it covers this fraction
/// of the remaining height per step.
const DESCENT_SPEED: f64 = 0.3;
/// See `DESCENT_SPEED`.
const DESCENT_GAIN: f64 = 0.5;
/// The hand pushes only once it moves vertically slower than this (m/s).
const STILL_SPEED: f64 = 0.05;
/// Height (m) above the cube's centre where the hand waits.
const WAIT_HEIGHT: f64 = 0.1;

/// The `flip` task's expert (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct FlipExpert;

/// The turn `psi` about the vertical that brings `a` closest to `b`, and the angle left.
fn best_spin(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> (f64, f64) {
    // Rz(psi) a = cos(psi/2) a + sin(psi/2) (k a), k the pure quaternion z: its dot with b is
    // alpha cos + beta sin, largest in magnitude at psi/2 = atan2(beta, alpha).
    let k = Quaternion::new(0.0, 0.0, 0.0, 1.0);
    let alpha = a.coords.dot(&b.coords);
    let beta = (k * a.into_inner()).coords.dot(&b.coords);
    let psi = 2.0 * beta.atan2(alpha);
    // Either sign of the quaternion: the shorter turn.
    let psi = (psi + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    let left = 2.0 * alpha.hypot(beta).min(1.0).acos();
    (psi, left)
}

/// What the cube should do next.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Move {
    /// Nothing: it is within the threshold.
    Done,
    /// Roll towards the horizontal direction given.
    Roll(Vector2<f64>),
    /// Turn by this angle (rad) about the vertical.
    Spin(f64),
}

/// The cube's frame seen from above: its up axis (the body axis nearest the vertical, in world
/// coordinates) and the directions of its side faces' normals (two of the four).
fn frame(rotation: &UnitQuaternion<f64>) -> (Vector3<f64>, [Vector2<f64>; 2]) {
    let axes = [
        rotation * Vector3::x(),
        rotation * Vector3::y(),
        rotation * Vector3::z(),
    ];
    let up_index = (0..3)
        .max_by(|&i, &j| axes[i].z.abs().total_cmp(&axes[j].z.abs()))
        .unwrap_or(2);
    let up = axes[up_index] * axes[up_index].z.signum();
    let mut sides = axes
        .iter()
        .enumerate()
        .filter(|&(i, _)| i != up_index)
        .map(|(_, a)| {
            let h = a.xy();
            h / h.norm().max(1e-9)
        });
    let first = sides.next().unwrap_or_else(Vector2::x);
    let second = Vector2::new(-first.y, first.x);
    (up, [first, second])
}

/// The first moves of the cheapest plans from `rotation` (the cube resting flat) to within
/// `threshold` of `goal` (several when plans tie: the caller picks the nearest, so rounding
/// does not switch the hand between them).
fn plan(rotation: &UnitQuaternion<f64>, goal: &UnitQuaternion<f64>, threshold: f64) -> Vec<Move> {
    if angle(rotation, goal) < threshold - DONE_MARGIN {
        return vec![Move::Done];
    }
    let (_, [d1, d2]) = frame(rotation);
    let directions = [d1, -d1, d2, -d2];
    // Rolling towards d turns the cube a quarter turn about z x d.
    let roll = |d: &Vector2<f64>| {
        let axis = Vector3::z().cross(&Vector3::new(d.x, d.y, 0.0));
        UnitQuaternion::from_scaled_axis(axis * std::f64::consts::FRAC_PI_2)
    };
    let rolls = directions.map(|d| roll(&d));
    // Every plan of up to MAX_ROLLS rolls (none straight back), with or without a spin at the
    // end, as (cost, angle left, first move).
    let mut plans: Vec<(f64, f64, Move)> = Vec::new();
    // (orientation, rolls so far, the first roll's index, the last roll's index)
    type Node = (UnitQuaternion<f64>, usize, Option<usize>, Option<usize>);
    let mut stack: Vec<Node> = vec![(*rotation, 0, None, None)];
    while let Some((r, depth, first, last)) = stack.pop() {
        let cost = depth as f64;
        let first_move = |otherwise| first.map_or(otherwise, |i: usize| Move::Roll(directions[i]));
        plans.push((cost, angle(&r, goal), first_move(Move::Done)));
        let (psi, left) = best_spin(&r, goal);
        let spin_cost = cost + SPIN_COST + SPIN_COST_PER_RAD * psi.abs();
        plans.push((spin_cost, left, first_move(Move::Spin(psi))));
        if depth < MAX_ROLLS {
            for (i, q) in rolls.iter().enumerate() {
                if last.is_none_or(|l| l ^ 1 != i) {
                    stack.push((q * r, depth + 1, first.or(Some(i)), Some(i)));
                }
            }
        }
    }
    // The cheapest plan ending `MARGIN` inside the threshold; failing that `DONE_MARGIN`
    // inside; failing that, the cheapest of those ending nearest the goal.
    let cheapest = |limit: f64| {
        let fitting = || plans.iter().filter(move |p| p.1 < limit);
        let least = fitting().map(|p| p.0).fold(f64::INFINITY, f64::min);
        let mut moves: Vec<Move> = Vec::new();
        for p in fitting().filter(|p| p.0 < least + TIE) {
            if !moves.iter().any(|m| m.same_as(&p.2)) {
                moves.push(p.2);
            }
        }
        (!moves.is_empty()).then_some(moves)
    };
    let nearest = plans.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    cheapest(threshold - MARGIN)
        .or_else(|| cheapest(threshold - DONE_MARGIN))
        .or_else(|| cheapest(nearest + NEAREST_TOLERANCE))
        .unwrap_or_else(|| vec![Move::Done])
}

impl Move {
    /// The same move, up to rounding.
    fn same_as(&self, other: &Move) -> bool {
        match (self, other) {
            (Move::Done, Move::Done) => true,
            (Move::Roll(a), Move::Roll(b)) => a.dot(b) > 0.99,
            (Move::Spin(a), Move::Spin(b)) => (a - b).abs() < 1e-6,
            _ => false,
        }
    }
}

/// How the hand pushes for a move.
struct Push {
    /// The horizontal direction pushed (into the face).
    direction: Vector2<f64>,
    /// Height (m) of the TCP above the resting cube's centre.
    height: f64,
    /// Pushing speed (a fraction of a full action; rolls follow their arc instead).
    speed: f64,
    phase: Phase,
    /// Along the face: `z x n`, `n = -direction` its outward normal.
    t: Vector2<f64>,
    /// Where on the face (seen from above) the fingers' centre line meets it.
    contact: Vector2<f64>,
    /// Where the hand lines up, `GAP` behind the face.
    line_up: Vector2<f64>,
}

impl Expert for FlipExpert {
    fn decide(&self, cx: &ExpertContext, observation: &[f32]) -> Result<Decision> {
        let s = &cx.slots;
        let h = cx.cube_half;
        let threshold = match &cx.config().task {
            TaskConfig::Flip(section) => section.angle_threshold,
            _ => panda_rapier_core::task::flip::PANDA_GYM_ANGLE_THRESHOLD,
        };
        let slot = |name: &str| cx.slot(name).map(|r| r.start);
        let (Some(position), Some(velocity), Some(spin)) = (
            slot("cube_position"),
            slot("cube_linear_velocity"),
            slot("cube_angular_velocity"),
        ) else {
            return Err(panda_rapier_core::Error::InvalidConfig {
                field: "task".into(),
                reason: "the flip expert needs the cube's slots".into(),
            });
        };
        let v3 = |start: usize| vector_at(observation, &(start..start + 3));
        let cube = v3(position);
        let rotation = quaternion(&observation[s.achieved.start..s.achieved.start + 4]);
        let goal = quaternion(&observation[s.desired.start..s.desired.start + 4]);
        let tcp = v3(s.tcp.start);
        let at_rest = v3(velocity).norm() < REST_SPEED && v3(spin).norm() < REST_SPIN;
        let decision = |phase, tcp_target, speed| Decision {
            hand: None,
            phase,
            tcp_target,
            speed,
            gain: 1.0,
            gripper: -1.0,
        };
        let over = cube.z + h + CLEARANCE;
        let relative = (tcp - cube).xy();
        // Leaving the cube alone: away from it sideways first while the fingers are beside it
        // (rising straight off a face drags the cube along), then up.
        let wait = |phase| {
            let distance = relative.norm();
            let near = distance < h * std::f64::consts::SQRT_2 + PUSHER_HALF_WIDTH + 0.01;
            if near && tcp.z < over {
                let away = cube.xy() + relative / distance.max(1e-9) * (distance + 0.02);
                return decision(phase, Vector3::new(away.x, away.y, tcp.z + 0.005), 1.0);
            }
            let above = Vector3::new(tcp.x, tcp.y, tcp.z.max(cube.z + WAIT_HEIGHT));
            decision(phase, above, 1.0)
        };
        let (up, _) = frame(&rotation);
        let tilt = up.z.min(1.0).acos();
        let lean = up.xy() / up.xy().norm().max(1e-9);
        // Heights are taken from the floor (the cube's centre rests at h): the pushing arm
        // sags under the contact, and aiming above by the shortfall corrects it.
        let level = |height: f64| {
            let z = h + height;
            z + (z - tcp.z).clamp(0.0, SAG_LIMIT)
        };
        // A roll: the cube tips over its bottom edge on the side it rolls towards (d), and the
        // fingers, pressed on its back face, go round that edge with the face, ROLL_STEP ahead
        // of its tilt. (Pushed straight ahead instead, the face rises against the fingers, whose
        // friction holds it down: the cube slides rather than tips.) Where the fingers are for
        // the tilt `phi`, and where they go next.
        let roll_arc = |d: Vector2<f64>, phi: f64| {
            let d3 = Vector3::new(d.x, d.y, 0.0);
            let axis = nalgebra::Unit::new_normalize(Vector3::z().cross(&d3));
            let tilted = |angle: f64| UnitQuaternion::from_axis_angle(&axis, angle);
            let edge = cube - tilted(phi) * (Vector3::z() * h - d3 * h);
            let fingers = Vector3::z() * (h + ROLL_HEIGHT) - d3 * (2.0 * h + PUSHER_HALF_WIDTH);
            (
                edge + tilted(phi) * fingers,
                edge + tilted(phi + ROLL_STEP) * fingers,
            )
        };
        if tilt > FLAT_TILT {
            // A roll under way: followed round until the cube topples, then left to fall.
            let (now, next) = roll_arc(lean, tilt);
            if tilt < TOPPLE_TILT && (tcp - now).norm() < ROLL_TRACK {
                return Ok(decision(Phase::ROLL, next, 1.0));
            }
            return Ok(wait(Phase::SETTLE));
        }
        // Each candidate move as (direction pushed, offset along the face, pushing height,
        // speed, phase), and the point behind the face where the hand lines up for it (a roll's
        // pushes follow `roll_arc`, not a speed).
        let setup = |m: Move| {
            let (direction, offset, height, speed, phase) = match m {
                Move::Done => return None,
                Move::Roll(d) => (d, 0.0, ROLL_HEIGHT, 0.0, Phase::ROLL),
                Move::Spin(psi) => {
                    // Push the face nearest the hand (so the choice holds while the cube
                    // turns), favouring the ones whose push drives the cube towards the middle
                    // of its region (spins drift it), off its centre on the side that turns it
                    // the right way: pushed along d at an offset e along t = z x n (n = -d,
                    // the face's outward normal), the cube turns anticlockwise for e > 0.
                    let (_, [d1, d2]) = frame(&rotation);
                    let inward = -(cube.xy() - Vector2::new(0.5, 0.0));
                    let inward = inward / inward.norm().max(1e-9);
                    let side = if psi >= 0.0 { 1.0 } else { -1.0 };
                    let line_up_of = |d: &Vector2<f64>| {
                        let t = Vector2::new(d.y, -d.x);
                        cube.xy() + t * (side * SPIN_OFFSET * h) - d * (h + PUSHER_HALF_WIDTH + GAP)
                    };
                    let score = |d: &Vector2<f64>| {
                        (tcp.xy() - line_up_of(d)).norm() - SPIN_INWARD_BIAS * d.dot(&inward)
                    };
                    let d = [d1, -d1, d2, -d2]
                        .into_iter()
                        .min_by(|a, b| score(a).total_cmp(&score(b)))
                        .unwrap_or(d1);
                    (
                        d,
                        side * SPIN_OFFSET * h,
                        SPIN_HEIGHT,
                        SPIN_SPEED,
                        Phase::SPIN,
                    )
                }
            };
            let t = Vector2::new(direction.y, -direction.x);
            let contact = cube.xy() + t * offset;
            Some(Push {
                direction,
                height,
                speed,
                phase,
                t,
                contact,
                line_up: contact - direction * (h + PUSHER_HALF_WIDTH + GAP),
            })
        };
        let chosen = plan(&rotation, &goal, threshold)
            .into_iter()
            .filter_map(setup)
            .min_by(|a, b| {
                let d = |p: &Push| (tcp.xy() - p.line_up).norm();
                d(a).total_cmp(&d(b))
            });
        let Some(Push {
            direction,
            height,
            speed,
            phase,
            t,
            contact,
            line_up,
        }) = chosen
        else {
            return Ok(wait(Phase::DONE));
        };
        let push_z = h + height;
        let along = (tcp.xy() - contact).dot(&direction);
        let low = tcp.z < over - 0.01;
        let behind = along < -(h + PUSHER_HALF_WIDTH);
        let sideways = (tcp.xy() - line_up).dot(&t).abs();
        let still = v3(s.tcp_velocity.start).z.abs() < STILL_SPEED;
        let at_height = (tcp.z - push_z).abs() < LINE_TOLERANCE && still;
        // Touching the face already (pushing): the contact may lift the hand a little.
        let touching = along > -(h + PUSHER_HALF_WIDTH + 0.005)
            && (tcp.z - push_z).abs() < 2.0 * LINE_TOLERANCE
            && sideways < 2.0 * LINE_TOLERANCE;
        let at = |xy: Vector2<f64>, z: f64| Vector3::new(xy.x, xy.y, z);
        if along < -0.5 * h && ((behind && sideways < LINE_TOLERANCE && at_height) || touching) {
            if phase == Phase::ROLL {
                return Ok(decision(phase, roll_arc(direction, tilt).1, 1.0));
            }
            // Push on along the line, level.
            let advance = direction * speed * cx.config().ee_step;
            let target = at(tcp.xy() + advance, level(height));
            return Ok(decision(phase, target, 1.0));
        }
        if !at_rest {
            // Moving (and not being pushed): wait for it to settle.
            return Ok(wait(Phase::SETTLE));
        }
        if low && behind {
            // Behind the face but off the line or the height: line up before touching.
            return Ok(Decision {
                hand: None,
                gain: DESCENT_GAIN,
                ..decision(Phase::LINE_UP, at(line_up, push_z), DESCENT_SPEED)
            });
        }
        if low {
            // Beside or in front of the cube: straight up first.
            return Ok(decision(Phase::LINE_UP, at(tcp.xy(), over + 0.01), 1.0));
        }
        // Above: over to the line-up point, then down once there, the last stretch in halves
        // and slowly (the dynamic arm overshoots downwards, and a hand landing beside the cube
        // knocks it).
        let off = (tcp.xy() - line_up).norm();
        if off < 0.01 {
            let speed = if tcp.z < push_z + DESCENT_HEIGHT {
                DESCENT_SPEED
            } else {
                1.0
            };
            return Ok(Decision {
                hand: None,
                gain: DESCENT_GAIN,
                ..decision(Phase::LINE_UP, at(line_up, push_z), speed)
            });
        }
        Ok(decision(Phase::LINE_UP, at(line_up, over + 0.01), 1.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_goal_a_roll_away_is_reached_by_that_roll() {
        let start = UnitQuaternion::identity();
        // Rolling towards +x turns the cube a quarter turn about +y.
        let goal = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2);
        match plan(&start, &goal, 0.9273)[..] {
            [Move::Roll(d)] => assert!((d - Vector2::x()).norm() < 1e-9, "{d}"),
            ref other => panic!("{other:?}"),
        }
        assert_eq!(plan(&goal, &goal, 0.9273), vec![Move::Done]);
    }

    #[test]
    fn the_best_spin_undoes_a_turn_about_the_vertical() {
        let start = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.3);
        let goal = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -1.2) * start;
        let (psi, left) = best_spin(&start, &goal);
        assert!((psi + 1.2).abs() < 1e-9 && left < 1e-6, "{psi} {left}");
    }

    #[test]
    fn plans_carried_out_exactly_reach_almost_every_goal() {
        // Rolls and spins carried out exactly, from the unturned cube, towards uniformly
        // random goals: every plan ends within the threshold, in a few moves, except near
        // the few orientations no face-up-and-heading reaches.
        // Shoemake's uniform rotations on a grid of its three uniform inputs.
        let threshold = panda_rapier_core::task::flip::PANDA_GYM_ANGLE_THRESHOLD;
        let k = 13;
        let (n, mut reached, mut moves_total) = (k * k * k, 0, 0);
        for index in 0..n {
            let u =
                [index % k, (index / k) % k, index / (k * k)].map(|i| (i as f64 + 0.5) / k as f64);
            let goal = panda_rapier_core::task::flip::uniform_orientation(u);
            let mut r = UnitQuaternion::identity();
            for moves in 0..8 {
                match plan(&r, &goal, threshold)[0] {
                    Move::Done => {
                        if angle(&r, &goal) < threshold {
                            reached += 1;
                            moves_total += moves;
                        }
                        break;
                    }
                    Move::Roll(d) => {
                        let axis = Vector3::z().cross(&Vector3::new(d.x, d.y, 0.0));
                        r = UnitQuaternion::from_scaled_axis(axis * std::f64::consts::FRAC_PI_2)
                            * r;
                    }
                    Move::Spin(psi) => {
                        r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), psi) * r;
                    }
                }
            }
        }
        assert!(reached as f64 / n as f64 > 0.99, "{reached} of {n}");
        assert!((moves_total as f64 / reached as f64) < 3.5, "{moves_total}");
    }
}
