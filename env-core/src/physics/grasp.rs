//! Top-down grasps planned from an object's shape ([`ObjectShape::top_grasp`]): where the
//! tool centre point should go, and which way the fingers should close, for a parallel
//! gripper coming straight down onto the object as it rests (its frame's z up), so that both
//! pads close on material narrower than the gripper opens, the open fingers and the hand come
//! down without touching the object, and the object hangs as close under the grasp as it can.
//! The scripted experts of tasks with objects of many shapes act on it.

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use rapier3d::geometry::{Cuboid, Ray, Shape, SharedShape};
use rapier3d::math::Pose;
use rapier3d::parry::query::intersection_test;

use super::convert::{pose_from_na, pose_to_na, vec_from_na, vec_to_na};
use super::shape::ObjectShape;
use crate::error::Result;

/// The parallel gripper's geometry a grasp must fit, in the tool centre point's frame: z along
/// the fingers (pointing down for a top-down grasp), the fingers closing along y.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GripperGeometry {
    /// The widest opening between the pads' inner faces (m).
    pub max_opening: f64,
    /// A pad's width across the closing direction (m).
    pub pad_width: f64,
    /// How far the pads reach below the tool centre point (towards the fingertips, m).
    pub pad_below: f64,
    /// How far the pads reach above the tool centre point (m).
    pub pad_above: f64,
    /// A finger's thickness along the closing direction (m).
    pub finger_thickness: f64,
    /// The height of the hand's lowest face above the tool centre point (m).
    pub hand_above: f64,
    /// The hand's half extents along the closing direction and across it (m).
    pub hand_half: [f64; 2],
}

impl GripperGeometry {
    /// The Franka hand of `assets/panda/panda.urdf`: pads 2 cm wide, 2.74 cm long, their tips
    /// 8.4 mm below the tool centre point; fingers opening to 8 cm; the hand's body from
    /// 4.5 cm above the tool centre point, 20.4 x 6.3 cm.
    pub const PANDA: Self = Self {
        max_opening: 0.08,
        pad_width: 0.02,
        pad_below: 0.0084,
        pad_above: 0.019,
        finger_thickness: 0.01,
        hand_above: 0.045,
        hand_half: [0.102, 0.0315],
    };
}

/// A top-down grasp in the object's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TopGrasp {
    /// Where the tool centre point goes (m, object frame).
    pub position: Vector3<f64>,
    /// The closing direction's angle about the object's z axis (rad, in [0, pi)): the fingers
    /// close along `(cos yaw, sin yaw, 0)`.
    pub yaw: f64,
    /// The material's width between the pads (m): the opening once closed.
    pub width: f64,
}

/// Closing directions tried: every 15 degrees of a half turn.
const YAWS: usize = 12;
/// Spacing of the grasp centres tried over the object's footprint (m).
const GRID: f64 = 0.005;
/// Heights of the tool centre point tried below the object's top (m).
const DEPTHS: [f64; 5] = [0.005, 0.012, 0.02, 0.03, 0.04];
/// Kept free between the open fingers and the object, and below the fingertips (m).
const CLEARANCE: f64 = 0.004;
/// The narrowest material worth closing on (m).
const MIN_WIDTH: f64 = 0.004;
/// The most a touched surface may be tilted from vertical (rad): steeper ones (a cone's side,
/// a pear's neck) push the object out of the pads as they squeeze.
const MAX_SLOPE: f64 = 0.3;
/// The most the surface in front of a pad's middle may be turned about z from facing it (rad).
const MAX_TURN: f64 = 0.5;
/// Weight (per metre of width) of the material's width in a grasp's score, against the
/// distance (m) of its centre from the centre of mass: a tie-break between grasps alike
/// otherwise.
const NARROW_WEIGHT: f64 = 0.1;
/// A pad touches what lies within this of the first material it meets (m): on a round
/// surface, the band around its widest line.
const TOUCH: f64 = 0.001;

impl ObjectShape {
    /// The best top-down grasp of the object resting with its frame's z up, for `gripper`; None
    /// if no closing direction and centre fit (wider than the gripper opens wherever the
    /// fingers could come down). Among the grasps that fit, the one whose pads are covered
    /// best (by rays across the pads' faces at seven heights and three offsets) and then whose
    /// centre lies nearest above the centre of mass (so the lifted object hangs straight),
    /// among equals across the narrowest material.
    ///
    /// # Errors
    /// The shape's own errors ([`ObjectShape::validate`]).
    pub fn top_grasp(&self, gripper: &GripperGeometry) -> Result<Option<TopGrasp>> {
        let (shape, local) = self.build("shape")?;
        let object = Placed {
            shape: &shape,
            pose: pose_from_na(&local),
            local,
        };
        let aabb = shape.compute_aabb(&object.pose);
        let (lo, hi) = (aabb.mins, aabb.maxs);
        let c = shape.mass_properties(1.0).local_com;
        let com = local * Point3::new(f64::from(c.x), f64::from(c.y), f64::from(c.z));
        let (bottom, top) = (f64::from(lo.z), f64::from(hi.z));

        let mut best: Option<(f64, TopGrasp)> = None;
        let nx = ((f64::from(hi.x - lo.x)) / GRID).ceil() as usize;
        let ny = ((f64::from(hi.y - lo.y)) / GRID).ceil() as usize;
        for k in 0..YAWS {
            let yaw = k as f64 * std::f64::consts::PI / YAWS as f64;
            let d = Vector3::new(yaw.cos(), yaw.sin(), 0.0);
            for i in 0..=nx {
                for j in 0..=ny {
                    let x = f64::from(lo.x) + i as f64 * GRID;
                    let y = f64::from(lo.y) + j as f64 * GRID;
                    for depth in DEPTHS {
                        let z = top - depth;
                        if z - gripper.pad_below < bottom + CLEARANCE {
                            continue;
                        }
                        let centre = Vector3::new(x, y, z);
                        let Some(candidate) = grasp_at(&object, top, centre, d, yaw, gripper)
                        else {
                            continue;
                        };
                        let (coverage, grasp) = candidate;
                        let offset = (grasp.position.xy() - com.coords.xy()).norm();
                        // Coverage first (in steps of 1/21), then the distance from the centre
                        // of mass, and among equals the narrower material (across a box's
                        // narrow side, not its wide one).
                        let score = -coverage + offset + NARROW_WEIGHT * grasp.width;
                        if best.as_ref().is_none_or(|(s, _)| score < *s) {
                            best = Some((score, grasp));
                        }
                    }
                }
            }
        }
        Ok(best.map(|(_, grasp)| grasp))
    }
}

/// The shape at its pose in the object's frame, in parry's and nalgebra's types (converted
/// once, not per ray).
struct Placed<'a> {
    shape: &'a SharedShape,
    pose: Pose,
    local: Isometry3<f64>,
}

/// The grasp centred where the pads touch when closing along `d` at about `centre` (the
/// object's top at height `top`), with its pad coverage (0 to 1), if it fits.
fn grasp_at(
    object: &Placed<'_>,
    top: f64,
    centre: Vector3<f64>,
    d: Vector3<f64>,
    yaw: f64,
    gripper: &GripperGeometry,
) -> Option<(f64, TopGrasp)> {
    let half_open = gripper.max_opening / 2.0;
    let e = Vector3::new(-d.y, d.x, 0.0);
    // Rays from each open pad's inner face towards the other, across the pad's face: three
    // offsets across it and seven heights.
    let offsets = [-0.35 * gripper.pad_width, 0.0, 0.35 * gripper.pad_width];
    // Seven heights over the pad, 4 mm apart on the Panda's.
    let heights: [f64; 7] = std::array::from_fn(|i| {
        let (low, high) = (-0.9 * gripper.pad_below, 0.9 * gripper.pad_above);
        low + (high - low) * i as f64 / 6.0
    });
    // Each ray's first contact: where along `d` (from `centre`) it meets the surface, the
    // surface's tilt from vertical there (rad), and, for the rays through the pad's middle,
    // how far it is turned about z from facing the pad (rad; None for the others).
    let mut contacts: [Vec<(f64, f64, Option<f64>)>; 2] = [Vec::new(), Vec::new()];
    for s in offsets {
        for h in heights {
            let origin = centre + s * e + Vector3::new(0.0, 0.0, h);
            for (k, side) in [1.0, -1.0].into_iter().enumerate() {
                let start = origin + side * half_open * d;
                let toward = -side * d;
                let Some((toi, n)) = cast(
                    object.shape.as_ref(),
                    &object.local,
                    start,
                    toward,
                    gripper.max_opening,
                ) else {
                    continue;
                };
                if toi <= 0.0 {
                    // The open pad would be inside the object.
                    return None;
                }
                let tilt = n.z.abs().clamp(0.0, 1.0).asin();
                let turned = (s == 0.0).then(|| {
                    let flat = Vector3::new(n.x, n.y, 0.0).normalize();
                    (-flat.dot(&toward)).clamp(-1.0, 1.0).acos()
                });
                contacts[k].push((side * (half_open - toi), tilt, turned));
            }
        }
    }
    // The closing pads stop at the first material each meets.
    let left = contacts[0]
        .iter()
        .map(|c| c.0)
        .fold(f64::NEG_INFINITY, f64::max);
    let right = contacts[1]
        .iter()
        .map(|c| c.0)
        .fold(f64::INFINITY, f64::min);
    // What each pad then touches: the contacts within TOUCH of where it stops. Its middle
    // must be among them (a pad touching at its edge only pinches a corner).
    let touching = |k: usize, stop: f64| -> Vec<(f64, Option<f64>)> {
        contacts[k]
            .iter()
            .filter(|c| (c.0 - stop).abs() < TOUCH)
            .map(|c| (c.1, c.2))
            .collect()
    };
    let (touch_left, touch_right) = (touching(0, left), touching(1, right));
    let middle = |touch: &[(f64, Option<f64>)]| touch.iter().any(|t| t.1.is_some());
    if touch_left.len() < 2
        || touch_right.len() < 2
        || !middle(&touch_left)
        || !middle(&touch_right)
    {
        return None;
    }
    // Surfaces tilted more than MAX_SLOPE from vertical wedge the object out of the pads as
    // they squeeze; faces turned more than MAX_TURN about z meet the pads at an edge (a box's
    // corner pinched across its diagonal).
    let touched = || touch_left.iter().chain(&touch_right);
    let slope = touched().map(|t| t.0).fold(0.0, f64::max);
    let turn = touched().filter_map(|t| t.1).fold(0.0, f64::max);
    if slope > MAX_SLOPE || turn > MAX_TURN {
        return None;
    }
    let (near, far) = (right, left);
    let width = far - near;
    if !(MIN_WIDTH..=gripper.max_opening - 2.0 * CLEARANCE).contains(&width) {
        return None;
    }
    // Centre the pads on the material: the coupled fingers close symmetrically.
    let position = centre + 0.5 * (far + near) * d;
    // The open fingers and the hand come down from above without touching the object: each
    // finger swept from its tip to above the object's top, the hand from its face up.
    let finger_half = Vector3::new(
        (gripper.finger_thickness + CLEARANCE) / 2.0,
        gripper.pad_width / 2.0,
        (top + 0.05 - (position.z - gripper.pad_below)) / 2.0,
    );
    let finger_z = (position.z - gripper.pad_below + top + 0.05) / 2.0;
    let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
    let clear = |half: Vector3<f64>, at: Vector3<f64>| {
        let cuboid = Cuboid::new(vec_from_na(&half));
        let place = pose_from_na(&Isometry3::from_parts(at.into(), rotation));
        // A pair parry cannot test counts as touching.
        !intersection_test(&object.pose, object.shape.as_ref(), &place, &cuboid)
            .map_or(true, |i| i.intersecting)
    };
    for side in [1.0, -1.0] {
        let at = position
            + side * (half_open + (gripper.finger_thickness - CLEARANCE) / 2.0) * d
            + Vector3::new(0.0, 0.0, finger_z - position.z);
        if !clear(finger_half, at) {
            return None;
        }
    }
    let hand_bottom = position.z + gripper.hand_above;
    let hand_half = Vector3::new(gripper.hand_half[0], gripper.hand_half[1], 0.05);
    if hand_bottom < top
        && !clear(
            hand_half,
            position + Vector3::new(0.0, 0.0, gripper.hand_above + 0.05),
        )
    {
        return None;
    }
    let coverage = touch_left.len().min(touch_right.len()) as f64 / 21.0;
    Some((
        coverage - 0.2 * slope,
        TopGrasp {
            position,
            yaw,
            width,
        },
    ))
}

/// The first point where a ray from `origin` along the unit vector `dir` meets `shape` (at
/// `pose`) within `max`: its distance and the outward surface normal there; distance 0 if the
/// origin is inside. Convex hulls are clipped face by face (exact, in f64): parry 0.31.1's GJK
/// ray cast put a hit on a 5 cm frustum 3 mm outside it, with a normal no face has. Other
/// shapes use parry's closed-form ray casts.
fn cast(
    shape: &dyn Shape,
    pose: &Isometry3<f64>,
    origin: Vector3<f64>,
    dir: Vector3<f64>,
    max: f64,
) -> Option<(f64, Vector3<f64>)> {
    if let Some(compound) = shape.as_compound() {
        let mut best: Option<(f64, Vector3<f64>)> = None;
        for (local, part) in compound.shapes() {
            let at = pose * pose_to_na(local);
            if let Some(hit) = cast(part.as_ref(), &at, origin, dir, max) {
                if best.is_none_or(|b| hit.0 < b.0) {
                    best = Some(hit);
                }
            }
        }
        return best;
    }
    if let Some(hull) = shape.as_convex_polyhedron() {
        let o = pose.inverse_transform_point(&origin.into()).coords;
        let d = pose.inverse_transform_vector(&dir);
        let (mut enter, mut exit) = (0.0, max);
        let mut normal = None;
        for face in hull.faces() {
            let n = vec_to_na(face.normal);
            let corner = hull.vertices_adj_to_face()[face.first_vertex_or_edge as usize];
            let p0 = vec_to_na(hull.points()[corner as usize]);
            let (along, gap) = (n.dot(&d), n.dot(&(p0 - o)));
            if along.abs() < 1e-12 {
                if gap < 0.0 {
                    return None;
                }
                continue;
            }
            let t = gap / along;
            if along < 0.0 {
                if t > enter {
                    enter = t;
                    normal = Some(n);
                }
            } else if t < exit {
                exit = t;
            }
            if enter > exit {
                return None;
            }
        }
        return Some(match normal {
            Some(n) => (enter, pose.rotation * n),
            None => (0.0, Vector3::zeros()),
        });
    }
    let ray = Ray::new(vec_from_na(&origin), vec_from_na(&dir));
    shape
        .cast_ray_and_get_normal(&pose_from_na(pose), &ray, max as f32, true)
        .map(|hit| (f64::from(hit.time_of_impact), vec_to_na(hit.normal)))
}
