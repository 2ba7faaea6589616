//! What touches an object: contacts with a positive impulse in the last physics step, by the
//! robot's links (fingers apart), the floor, the platform and the other objects.

use super::{ObjectId, Simulation};

/// What touches an object right now, with the robot's links listed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ObjectContacts {
    /// Robot links (indices into [`crate::RobotModel::links`]) with an active contact.
    pub robot_links: Vec<usize>,
    /// Normal contact force (N) each of those links pushes the object with, in the same order.
    pub robot_forces: Vec<f64>,
    /// Touching the floor.
    pub floor: bool,
    /// Touching the platform.
    pub platform: bool,
    /// The other objects it touches, in [`crate::physics::Scene::objects`] order.
    pub objects: Vec<ObjectId>,
}

/// What touches an object, summarised without allocating (read every control step).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ObjectTouch {
    /// Normal force (N) from each finger (the gripper's driving joint's finger first); 0 when
    /// not touching. Robots with one finger report 0 for the second.
    pub finger_forces: [f64; 2],
    /// Normal force (N) from robot links other than the fingers.
    pub other_robot_force: f64,
    /// Touching the floor.
    pub floor: bool,
    /// Touching the platform.
    pub platform: bool,
    /// The other objects it touches: bit `i` for the object with index `i` (objects past the
    /// 64th are not reported).
    pub objects: u64,
}

impl ObjectTouch {
    /// Whether any robot link touches the object.
    pub fn robot_touching(&self) -> bool {
        self.finger_forces.iter().any(|&f| f > 0.0) || self.other_robot_force > 0.0
    }

    /// Whether it touches `object`.
    pub fn touches(&self, object: ObjectId) -> bool {
        object.0 < 64 && self.objects & (1 << object.0) != 0
    }
}

/// The contact between two objects in the last physics step: how deep they overlap and how
/// hard they press (what a tight fit such as a peg in its hole is judged by).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PairContact {
    /// Contact points the solver saw.
    pub points: usize,
    /// Deepest overlap (m, 0 when none) among them: the solver lets shapes sink into each
    /// other by up to about its allowed error before it pushes them apart.
    pub penetration: f64,
    /// Total normal force (N) between the two, summed over the points.
    pub normal_force: f64,
}

/// One body an object touches, as `Simulation::for_each_contact` reports it.
enum Contact {
    Floor,
    Platform,
    /// Another object.
    Object(ObjectId),
    /// A robot link (index into the model's links) and its normal force (N).
    Robot {
        link: usize,
        force: f64,
    },
}

impl Simulation {
    /// What `object` touches right now (contacts with a positive impulse in the last step).
    pub fn object_contacts(&self, object: ObjectId) -> ObjectContacts {
        let mut contacts = ObjectContacts::default();
        self.for_each_contact(object, |contact| match contact {
            Contact::Floor => contacts.floor = true,
            Contact::Platform => contacts.platform = true,
            Contact::Object(other) => {
                if !contacts.objects.contains(&other) {
                    contacts.objects.push(other);
                }
            }
            Contact::Robot { link, force } => {
                match contacts.robot_links.iter().position(|&l| l == link) {
                    Some(i) => contacts.robot_forces[i] += force,
                    None => {
                        contacts.robot_links.push(link);
                        contacts.robot_forces.push(force);
                    }
                }
            }
        });
        contacts.objects.sort_by_key(|o| o.0);
        contacts
    }

    /// What touches `object`, summarised without allocating (contacts with a positive impulse
    /// in the last physics step).
    pub fn object_touch(&self, object: ObjectId) -> ObjectTouch {
        let mut touch = ObjectTouch::default();
        let fingers = self.gripper.as_ref().map_or(&[][..], |g| &g.finger_links);
        self.for_each_contact(object, |contact| match contact {
            Contact::Floor => touch.floor = true,
            Contact::Platform => touch.platform = true,
            Contact::Object(other) => {
                if other.0 < 64 {
                    touch.objects |= 1 << other.0;
                }
            }
            Contact::Robot { link, force } => match fingers.iter().position(|&l| l == link) {
                Some(i) if i < 2 => touch.finger_forces[i] += force,
                _ => touch.other_robot_force += force,
            },
        });
        touch
    }

    /// How `a` and `b` touch (all zero when they do not, or for an id of another world's
    /// object).
    pub fn contact_between(&self, a: ObjectId, b: ObjectId) -> PairContact {
        let collider = |o: ObjectId| self.objects.get(o.0).map(|o| o.collider);
        let (Some(ca), Some(cb)) = (collider(a), collider(b)) else {
            return PairContact::default();
        };
        let Some(pair) = self.world.narrow_phase.contact_pair(ca, cb) else {
            return PairContact::default();
        };
        let mut contact = PairContact::default();
        for manifold in pair.solver_manifolds() {
            for point in &manifold.points {
                contact.points += 1;
                contact.penetration = contact.penetration.max(-point.dist as f64);
                contact.normal_force += point.data.impulse.abs() as f64;
            }
        }
        contact.normal_force /= self.config.physics.solver.dt;
        contact
    }

    /// Joints or constraints of any kind that attach `object` to another body. The grasp is
    /// frictional, so this is 0.
    pub fn constraints_on(&self, object: ObjectId) -> usize {
        let Some(body) = self.objects.get(object.0).map(|o| o.body) else {
            return 0;
        };
        self.world.impulse_joints.attached_joints(body).count()
            + self.world.multibody_joints.attached_joints(body).count()
    }

    /// Calls `visit` for every collider pair of `object` with an active contact.
    fn for_each_contact(&self, object: ObjectId, mut visit: impl FnMut(Contact)) {
        let Some(collider) = self.objects.get(object.0).map(|o| o.collider) else {
            return;
        };
        for pair in self.world.narrow_phase.contact_pairs_with(collider) {
            if !pair.has_any_active_contact() {
                continue;
            }
            let other = if pair.collider1 == collider {
                pair.collider2
            } else {
                pair.collider1
            };
            if other == self.floor_collider {
                visit(Contact::Floor);
            } else if Some(other) == self.platform_collider {
                visit(Contact::Platform);
            } else if let Some(i) = self.objects.iter().position(|o| o.collider == other) {
                visit(Contact::Object(ObjectId(i)));
            } else if let Some(&(_, link)) = self.robot_colliders.iter().find(|(c, _)| *c == other)
            {
                let force = pair.total_impulse().length() as f64 / self.config.physics.solver.dt;
                visit(Contact::Robot { link, force });
            }
        }
    }
}
