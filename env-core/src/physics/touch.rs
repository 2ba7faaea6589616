//! Touch: the contact forces on each finger and the wrist's force-torque reading, as means
//! over the last control step (the physics steps since [`Simulation::begin_touch_window`],
//! which [`Simulation::step_control`] and the environment's control step call): the contact
//! impulses of its physics steps and the hand's motion over it.
//!
//! Each physics step's contact impulse is divided by its length (`physics.solver.dt`; rapier
//! sums each contact's impulse over its solver substeps) and the forces are averaged over the
//! window's physics steps: a mean force in newtons, as a force sensor sampled at the control
//! rate behind a boxcar anti-aliasing filter reads. (The arm's joint motors correct their
//! targets at the control rate, so within a control step the hand's acceleration swings
//! by about 1 m/s^2 even when it holds still: a single physics step's reading would carry
//! that.)

use nalgebra::Vector3;
use rapier3d::dynamics::{RigidBody, RigidBodyHandle};
use rapier3d::geometry::ColliderHandle;
use rapier3d::math::{Rotation, Vector};
use rapier3d::utils::OrthonormalBasis;

use super::convert::{rot_to_na, vec_to_na};
use super::Simulation;

/// Contact forces on one finger, means over the last control step, over all its contacts
/// (objects, floor, platform, other links).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FingerTouch {
    /// Sum of the normal contact forces' magnitudes (N, >= 0).
    pub normal_force: f64,
    /// Sum of the contact force vectors on the finger, normal and friction (N, world frame).
    pub force: Vector3<f64>,
}

/// A force and a torque (a wrench).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Wrench {
    /// Force (N).
    pub force: Vector3<f64>,
    /// Torque (N m).
    pub torque: Vector3<f64>,
}

/// What the robot's hand feels ([`Simulation::touch`]): contact forces on each finger and the
/// wrist's force-torque reading.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TouchReading {
    /// Each finger (the gripper's driving joint's finger first); zeros for a missing finger.
    pub fingers: [FingerTouch; 2],
    /// The wrench the hand subtree (the gripper's hand link, its fingers and any object
    /// [`Simulation::attach`]ed to it) exerts on the arm, expressed in the hand link's frame,
    /// torque about the hand frame's origin (the flange): a still, empty hand reads its own
    /// weight, pointing down. See [`Simulation::wrist_wrench`].
    pub wrist: Wrench,
}

impl TouchReading {
    /// Values of [`TouchReading::observation`].
    pub const LEN: usize = 14;

    /// The layout of [`TouchReading::observation`]: `(name, first index, count)` of each part.
    /// The one definition of the touch observation entry every layer reads.
    pub const LAYOUT: [(&'static str, usize, usize); 4] = [
        ("finger_normal_forces", 0, 2),
        ("finger_forces", 2, 6),
        ("wrist_force", 8, 3),
        ("wrist_torque", 11, 3),
    ];

    /// The largest magnitude of an observation value (N or N m): values beyond are clamped,
    /// as the state vector's entries are bounded (an impact can read thousands of newtons
    /// for one step).
    pub const BOUND: f64 = 1000.0;

    /// The reading as the float32 observation entry: finger normal forces (2, N), finger
    /// force vectors (2 x 3, N, world frame), wrist force (3, N, hand frame), wrist torque
    /// (3, N m, hand frame, about the hand origin), each clamped to `+-BOUND`.
    pub fn observation(&self) -> [f32; Self::LEN] {
        let [a, b] = &self.fingers;
        let values = [
            a.normal_force,
            b.normal_force,
            a.force.x,
            a.force.y,
            a.force.z,
            b.force.x,
            b.force.y,
            b.force.z,
            self.wrist.force.x,
            self.wrist.force.y,
            self.wrist.force.z,
            self.wrist.torque.x,
            self.wrist.torque.y,
            self.wrist.torque.z,
        ];
        let mut out = [0.0f32; Self::LEN];
        for (o, v) in out.iter_mut().zip(values) {
            // NaN (a blown-up world) stays NaN; the environment stops such episodes.
            *o = v.clamp(-Self::BOUND, Self::BOUND) as f32;
        }
        out
    }
}

/// The velocity and angular momentum of one body of the hand subtree at the start of the
/// touch window, and its motion after the window's last physics step (the rates over the
/// window follow from the two when the wrist is read, not on every step).
#[derive(Debug, Clone, Copy)]
struct BodyRate {
    body: RigidBodyHandle,
    /// Velocity of the centre of mass at the window's start (m/s).
    velocity: Vector3<f64>,
    /// Angular momentum about the centre of mass at the window's start (kg m^2/s).
    momentum: Vector3<f64>,
    /// Linear and angular velocity and orientation after the window's last physics step
    /// (`None` before its first).
    end: Option<(Vector, Vector, Rotation)>,
}

impl BodyRate {
    /// Mean acceleration of the centre of mass (m/s^2) and mean rate of the angular momentum
    /// (N m) over a window of `span` seconds, for a body of mass properties `rb`'s; zeros
    /// before the window's first step.
    fn rates(&self, rb: &RigidBody, span: f64) -> (Vector3<f64>, Vector3<f64>) {
        match self.end {
            Some((linvel, angvel, rotation)) => (
                (vec_to_na(linvel) - self.velocity) / span,
                (angular_momentum(rb, rotation, angvel) - self.momentum) / span,
            ),
            None => (Vector3::zeros(), Vector3::zeros()),
        }
    }
}

/// What the touch reading is computed from: sums over the physics steps of the window (the
/// last control step) and the hand subtree's motion over it. Part of snapshots.
#[derive(Debug, Clone, Default)]
pub(super) struct TouchWindow {
    /// Physics steps summed.
    steps: u32,
    /// Per finger: the summed normal force and force vector (N, world frame), over the steps.
    fingers: [(f64, Vector3<f64>); 2],
    /// The contact forces on the hand subtree from outside it, summed over the steps (N, world
    /// frame), and their moments about the world origin (N m).
    contact_force: Vector3<f64>,
    contact_moment: Vector3<f64>,
    /// The hand subtree's bodies.
    bodies: Vec<BodyRate>,
}

impl TouchWindow {
    /// A window with room for `bodies` bodies (stepping then never allocates).
    pub(super) fn with_capacity(bodies: usize) -> Self {
        Self {
            bodies: Vec::with_capacity(bodies),
            ..Self::default()
        }
    }

    /// Restores `other` into `self`, keeping this buffer's capacity.
    pub(super) fn copy_from(&mut self, other: &Self) {
        self.steps = other.steps;
        self.fingers = other.fingers;
        self.contact_force = other.contact_force;
        self.contact_moment = other.contact_moment;
        self.bodies.clone_from(&other.bodies);
    }
}

/// Angular momentum about the centre of mass (world frame) of a body with `rb`'s mass
/// properties, turned by `rotation` and spinning at `angvel`.
fn angular_momentum(rb: &RigidBody, rotation: Rotation, angvel: Vector) -> Vector3<f64> {
    let local = rb
        .mass_properties()
        .local_mprops
        .reconstruct_inertia_matrix();
    let inertia = nalgebra::Matrix3::from_fn(|i, j| local.col(j)[i] as f64);
    let r = rot_to_na(rotation).to_rotation_matrix();
    (r.matrix() * inertia * r.matrix().transpose()) * vec_to_na(angvel)
}

impl Simulation {
    /// The hand subtree's bodies: the gripper's hand link, the links below it, and the objects
    /// attached to it.
    fn hand_subtree_bodies(&self) -> impl Iterator<Item = RigidBodyHandle> + '_ {
        let objects = self
            .attachments
            .iter()
            .filter_map(|(o, _)| self.objects.get(o.0).map(|o| o.body));
        self.hand_links
            .iter()
            .filter_map(|&l| self.link_bodies[l])
            .chain(objects)
    }

    /// Whether `collider` belongs to the hand subtree.
    fn in_hand_subtree(&self, collider: ColliderHandle) -> bool {
        self.robot_colliders
            .iter()
            .any(|&(c, l)| c == collider && self.hand_links.contains(&l))
            || self.attachments.iter().any(|(o, _)| {
                self.objects
                    .get(o.0)
                    .is_some_and(|o| o.collider == collider)
            })
    }

    /// Starts a new touch window: [`Simulation::touch`] then reads the mean over the physics
    /// steps taken from here on. [`Simulation::step_control`] and the environment's control
    /// step start one each (so the reading is the last control step's mean); a bare
    /// [`Simulation::step`] adds to the current window. A window that holds no step reads no
    /// contact and no motion (the hand's static weight).
    pub fn begin_touch_window(&mut self) {
        let mut window = std::mem::take(&mut self.touch_window);
        window.steps = 0;
        window.fingers = Default::default();
        window.contact_force = Vector3::zeros();
        window.contact_moment = Vector3::zeros();
        window.bodies.clear();
        for body in self.hand_subtree_bodies() {
            if let Some(rb) = self.world.bodies.get(body) {
                window.bodies.push(BodyRate {
                    body,
                    velocity: vec_to_na(rb.linvel()),
                    momentum: angular_momentum(rb, *rb.rotation(), rb.angvel()),
                    end: None,
                });
            }
        }
        self.touch_window = window;
    }

    /// Adds the physics step just taken to the touch window.
    pub(super) fn accumulate_touch(&mut self) {
        let mut window = std::mem::take(&mut self.touch_window);
        window.steps += 1;
        let fingers = self.gripper.as_ref().map_or(&[][..], |g| &g.finger_links);
        for (finger, sum) in fingers.iter().zip(window.fingers.iter_mut()) {
            for &(collider, link) in &self.robot_colliders {
                if link == *finger {
                    sum.0 += self.visit_contact_forces(collider, |_| false, |_, f| sum.1 += f);
                }
            }
        }
        let (force, moment) = (&mut window.contact_force, &mut window.contact_moment);
        let hand = self
            .robot_colliders
            .iter()
            .filter_map(|&(c, l)| self.hand_links.contains(&l).then_some(c));
        let attached = self
            .attachments
            .iter()
            .filter_map(|(o, _)| self.objects.get(o.0).map(|o| o.collider));
        for collider in hand.chain(attached) {
            self.visit_contact_forces(
                collider,
                |other| self.in_hand_subtree(other),
                |p, f| {
                    *force += f;
                    *moment += p.cross(&f);
                },
            );
        }
        for rate in &mut window.bodies {
            if let Some(rb) = self.world.bodies.get(rate.body) {
                rate.end = Some((rb.linvel(), rb.angvel(), *rb.rotation()));
            }
        }
        self.touch_window = window;
    }

    /// Calls `visit(point, force)` for every contact of `collider` in the last physics step
    /// whose other collider `skip` does not exclude: the world contact point and the force
    /// (N, world frame, normal plus friction) on `collider`, and returns the summed normal
    /// force (N).
    fn visit_contact_forces(
        &self,
        collider: ColliderHandle,
        skip: impl Fn(ColliderHandle) -> bool,
        mut visit: impl FnMut(Vector3<f64>, Vector3<f64>),
    ) -> f64 {
        let dt = self.config.physics.solver.dt;
        let mut normal_force = 0.0;
        for pair in self.world.narrow_phase.contact_pairs_with(collider) {
            if !pair.has_any_active_contact() {
                continue;
            }
            let first = pair.collider1 == collider;
            if skip(if first {
                pair.collider2
            } else {
                pair.collider1
            }) {
                continue;
            }
            for manifold in pair.solver_manifolds() {
                // The solver pushes the first collider's body along `-normal`, with friction
                // along the tangent basis it derives from that direction (rapier's
                // `compute_tangent_contact_directions`); the second body gets the opposite.
                let dir1: Vector = -manifold.data.normal;
                let t1 = dir1.orthonormal_vector();
                let t2 = dir1.cross(t1);
                for contact in &manifold.data.solver_contacts {
                    let id = contact.contact_indices()[0] as usize;
                    let Some(point) = manifold.points.get(id) else {
                        continue;
                    };
                    let data = &point.data;
                    let on_first = dir1 * data.impulse
                        + t1 * data.tangent_impulse.x
                        + t2 * data.tangent_impulse.y;
                    let force = vec_to_na(if first { on_first } else { -on_first }) / dt;
                    let (p1, p2) = manifold
                        .data
                        .solver_contact_world_points(contact, &self.world.bodies);
                    visit(vec_to_na((p1 + p2) * 0.5), force);
                    normal_force += data.impulse as f64 / dt;
                }
            }
        }
        normal_force
    }

    /// Contact forces on each finger, means over the last control step (see [`FingerTouch`]
    /// and the module's notes); zeros without a gripper or before the first step.
    pub fn finger_touch(&self) -> [FingerTouch; 2] {
        let w = &self.touch_window;
        let n = w.steps.max(1) as f64;
        w.fingers.map(|(normal, force)| FingerTouch {
            normal_force: normal / n,
            force: force / n,
        })
    }

    /// The wrist force-torque reading: the wrench the hand subtree (the gripper's hand link,
    /// the links below it, the fingers, and any object [`Simulation::attach`]ed to the hand)
    /// exerts on the arm, by Newton-Euler on the subtree over the touch window (the last
    /// control step, see [`Simulation::begin_touch_window`]):
    ///
    /// `F = sum_i m_i (g - a_i) + sum_c F_c`,
    /// `T = sum_i [(c_i - o) x m_i (g - a_i) - dL_i/dt] + sum_c (p_c - o) x F_c`,
    ///
    /// with `m_i`, `c_i`, `a_i`, `dL_i/dt` each body's mass, centre of mass, its mean
    /// acceleration and rate of angular momentum over the window, `F_c` the mean contact
    /// forces on the subtree from outside it (at points `p_c`) and `o` the hand frame's
    /// origin (the
    /// flange). Both are returned in the hand frame: a still, empty hand reads its weight,
    /// pointing down (the world's `-z` expressed in the hand frame). Zero without a gripper.
    pub fn wrist_wrench(&self) -> Wrench {
        let Some(hand) = self.hand_links.first().and_then(|&l| self.link_bodies[l]) else {
            return Wrench::default();
        };
        let Some(hand_rb) = self.world.bodies.get(hand) else {
            return Wrench::default();
        };
        let origin = vec_to_na(hand_rb.translation());
        let g = Vector3::from(self.config.physics.gravity);
        let mut force = Vector3::zeros();
        let mut torque = Vector3::zeros();
        for body in self.hand_subtree_bodies() {
            let Some(rb) = self.world.bodies.get(body) else {
                continue;
            };
            let mass = rb.mass_properties().local_mprops.mass() as f64;
            let span = self.touch_window.steps as f64 * self.config.physics.solver.dt;
            let rate = self.touch_window.bodies.iter().find(|r| r.body == body);
            let (a, dl) = rate.map_or((Vector3::zeros(), Vector3::zeros()), |r| r.rates(rb, span));
            let f = mass * (g - a);
            force += f;
            torque += (vec_to_na(rb.center_of_mass()) - origin).cross(&f) - dl;
        }
        let w = &self.touch_window;
        let n = w.steps.max(1) as f64;
        force += w.contact_force / n;
        // Moments about the world origin, moved to the hand's: sum (p - o) x F.
        torque += (w.contact_moment - origin.cross(&w.contact_force)) / n;
        let to_hand = rot_to_na(*hand_rb.rotation()).inverse();
        Wrench {
            force: to_hand * force,
            torque: to_hand * torque,
        }
    }

    /// Mass (kg) of the hand subtree the wrist reading weighs ([`Simulation::wrist_wrench`]):
    /// the hand, the fingers and any attached object.
    pub fn hand_subtree_mass(&self) -> f64 {
        self.hand_subtree_bodies()
            .filter_map(|b| self.world.bodies.get(b))
            .map(|rb| rb.mass_properties().local_mprops.mass() as f64)
            .sum()
    }

    /// What the hand feels: [`Simulation::finger_touch`] and [`Simulation::wrist_wrench`].
    pub fn touch(&self) -> TouchReading {
        TouchReading {
            fingers: self.finger_touch(),
            wrist: self.wrist_wrench(),
        }
    }
}
