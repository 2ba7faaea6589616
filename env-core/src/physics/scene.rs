//! What a world holds besides the robot and the floor: the platform and the movable objects a
//! task asks for, reached through named handles.

use std::sync::Arc;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rapier3d::geometry::SharedShape;
use rapier3d::math::Vector;

use rapier3d::dynamics::FixedJointBuilder;

use super::convert::{pose_from_na, pose_to_na, vec_to_na};
use super::shape::ObjectShape;
use super::visuals::ObjectVisual;
use super::{ArticulationSpec, BodyState, SceneObject, Simulation};
use crate::config::{non_negative, positive, CubeConfig, PlatformConfig};
use crate::error::{ensure_all_finite, Error, Result};

/// The platform and movable objects of a world, and the floor they stand on. The default is an
/// empty world: no platform, no objects, the configured floor (tasks list what they need and
/// leave the rest to `..Scene::default()`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scene {
    /// The platform, when one stands in the world.
    pub platform: Option<PlatformConfig>,
    /// The movable objects; an object's [`ObjectId`] is its position here.
    pub objects: Vec<ObjectSpec>,
    /// The articulated objects (a cabinet with a drawer); an [`super::ArticulationId`] is a position
    /// here.
    pub articulations: Vec<ArticulationSpec>,
    /// A slippery floor: its friction coefficient in this world, combined with a touching
    /// body's by taking the smaller of the two, so every object slides on it as on ice of
    /// that friction whatever its own. `None`: the configured `physics.floor_friction`,
    /// averaged with the touching body's (rapier's default rule).
    pub floor_friction: Option<f64>,
}

/// One object of a scene: a body of some [`ObjectShape`] that moves (a cube, a peg) or a
/// fixture that stays where the task puts it (a box with a hole).
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectSpec {
    /// Unique name ([`Simulation::object`] looks it up).
    pub name: String,
    /// Its shape in its own frame.
    pub shape: ObjectShape,
    /// Mass (kg), spread uniformly over the shape (unused by a fixture, but still > 0).
    pub mass: f64,
    /// Friction coefficient.
    pub friction: f64,
    /// Where its frame starts (m, world frame); tasks place it at every reset.
    pub position: [f64; 3],
    /// A fixture: a fixed body that nothing moves but [`Simulation::set_object_pose`] (and a
    /// kinematic arm cannot enter, as the floor and the platform).
    pub fixed: bool,
    /// How it looks, by variant ([`Simulation::object_variant`]: a task that draws its
    /// object from a set gives one entry per object of the set); a variant without an entry,
    /// or with an empty one, is drawn as its collision shape. Drawing only: the physics never
    /// reads it.
    pub visuals: Vec<Arc<ObjectVisual>>,
}

impl ObjectSpec {
    /// A cube named `name` with the size, mass and friction of `cube`, at `position`.
    pub fn cube(name: &str, cube: &CubeConfig, position: [f64; 3]) -> Self {
        Self {
            name: name.into(),
            shape: ObjectShape::cube(cube.size),
            mass: cube.mass,
            friction: cube.friction,
            position,
            fixed: false,
            visuals: Vec::new(),
        }
    }
}

impl Scene {
    /// Where the classic tutorial's cube starts: on the floor in front of the robot.
    pub const TUTORIAL_CUBE_POSITION: [f64; 3] = [0.5, -0.15, 0.025];

    /// The classic tutorial's scene: the default platform and one default cube named `"cube"`
    /// at [`Scene::TUTORIAL_CUBE_POSITION`].
    pub fn tutorial() -> Self {
        Self {
            platform: Some(PlatformConfig::default()),
            objects: vec![ObjectSpec::cube(
                "cube",
                &CubeConfig::default(),
                Self::TUTORIAL_CUBE_POSITION,
            )],
            ..Self::default()
        }
    }

    /// Checks the platform and every object (finite values, positive sizes and masses, unique
    /// names).
    pub fn validate(&self) -> Result<()> {
        if let Some(platform) = &self.platform {
            platform.validate("scene.platform")?;
        }
        if let Some(friction) = self.floor_friction {
            non_negative("scene.floor_friction", friction)?;
        }
        for (i, object) in self.objects.iter().enumerate() {
            let field = |what: &str| format!("scene.objects[{i}].{what}");
            object.shape.validate(&field("shape"))?;
            positive(&field("mass"), object.mass)?;
            non_negative(&field("friction"), object.friction)?;
            ensure_all_finite(&field("position"), &object.position)?;
            if self.objects[..i].iter().any(|o| o.name == object.name) {
                return Err(Error::InvalidConfig {
                    field: field("name"),
                    reason: format!("`{}` is used twice", object.name),
                });
            }
        }
        for (i, articulation) in self.articulations.iter().enumerate() {
            let field = format!("scene.articulations[{i}]");
            articulation.validate(&field)?;
            if self.articulations[..i]
                .iter()
                .any(|a| a.name == articulation.name)
            {
                return Err(Error::InvalidConfig {
                    field: format!("{field}.name"),
                    reason: format!("`{}` is used twice", articulation.name),
                });
            }
        }
        Ok(())
    }
}

/// A movable object of a [`Simulation`], from [`Simulation::object`] or
/// [`Simulation::object_ids`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ObjectId(pub(super) usize);

impl ObjectId {
    /// The first object of a scene (before a task has looked its objects up by name).
    pub(crate) fn first() -> Self {
        Self(0)
    }

    /// The object's position in [`Scene::objects`].
    pub fn index(self) -> usize {
        self.0
    }
}

impl Simulation {
    /// The object named `name`.
    pub fn object(&self, name: &str) -> Result<ObjectId> {
        self.scene
            .objects
            .iter()
            .position(|o| o.name == name)
            .map(ObjectId)
            .ok_or_else(|| Error::UnknownLink {
                name: name.into(),
                known: self
                    .scene
                    .objects
                    .iter()
                    .map(|o| o.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// Every object, in [`Scene::objects`] order.
    pub fn object_ids(&self) -> impl Iterator<Item = ObjectId> {
        (0..self.objects.len()).map(ObjectId)
    }

    /// The bodies of `object`; an id from a world with fewer objects is an error.
    fn scene_object(&self, object: ObjectId) -> Result<&SceneObject> {
        self.objects
            .get(object.0)
            .ok_or_else(|| Error::UnknownLink {
                name: format!("object #{}", object.0),
                known: format!("{} objects in this scene", self.objects.len()),
            })
    }

    /// Pose and velocity of an object's centre (NaN for an id of another world's object).
    pub fn object_state(&self, object: ObjectId) -> BodyState {
        match self.objects.get(object.0) {
            Some(o) => self.body_state(o.body),
            None => BodyState::nan(),
        }
    }

    /// Teleports an object to `position` / `orientation`, at rest.
    pub fn set_object_pose(
        &mut self,
        object: ObjectId,
        position: &Vector3<f64>,
        orientation: &UnitQuaternion<f64>,
    ) -> Result<()> {
        ensure_all_finite("object position", position.as_slice())?;
        ensure_all_finite("object orientation", orientation.coords.as_slice())?;
        let body = self.scene_object(object)?.body;
        if let Some(rb) = self.world.bodies.get_mut(body) {
            let pose = Isometry3::from_parts(Translation3::from(*position), *orientation);
            rb.set_position(pose_from_na(&pose), true);
            rb.set_linvel(Vector::ZERO, true);
            rb.set_angvel(Vector::ZERO, true);
            rb.reset_forces(true);
        }
        Ok(())
    }

    /// Changes a cube's edge length, mass and friction (domain randomisation); its pose and
    /// velocity are kept. Objects of other shapes than a cube are refused.
    pub fn set_object_properties(
        &mut self,
        object: ObjectId,
        size: f64,
        mass: f64,
        friction: f64,
    ) -> Result<()> {
        for (field, value) in [("object size", size), ("object mass", mass)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::InvalidConfig {
                    field: field.into(),
                    reason: format!("must be finite and > 0, got {value}"),
                });
            }
        }
        if !(friction.is_finite() && friction >= 0.0) {
            return Err(Error::InvalidConfig {
                field: "object friction".into(),
                reason: format!("must be finite and >= 0, got {friction}"),
            });
        }
        let collider = self.scene_object(object)?.collider;
        if self.scene.objects[object.0].shape.cube_size().is_none() {
            return Err(Error::InvalidConfig {
                field: format!("scene.objects[{}].shape", object.0),
                reason: format!(
                    "only a cube's size can be changed, and `{}` is no cube",
                    self.scene.objects[object.0].name
                ),
            });
        }
        if let Some(collider) = self.world.colliders.get_mut(collider) {
            let half = (size / 2.0) as f32;
            collider.set_shape(SharedShape::cuboid(half, half, half));
            collider.set_mass(mass as f32);
            collider.set_friction(friction as f32);
        }
        Ok(())
    }

    /// Gives `object` another shape (a task that draws its objects' sizes per episode, such as
    /// peg insertion's peg and hole); its mass, friction, pose and velocity are kept, its
    /// inertia follows the new shape. The shape is checked as a scene's are, errors naming
    /// `scene.objects[i].shape`. [`Simulation::object_shape`] keeps reporting the shape the
    /// world was built with; snapshots and renderings see the new one.
    pub fn set_object_shape(&mut self, object: ObjectId, shape: &ObjectShape) -> Result<()> {
        let collider = self.scene_object(object)?.collider;
        let field = format!("scene.objects[{}].shape", object.0);
        shape.validate(&field)?;
        let (built, local) = shape.build(&field)?;
        if let Some(collider) = self.world.colliders.get_mut(collider) {
            collider.set_shape(built);
            collider.set_position_wrt_parent(pose_from_na(&local));
        }
        Ok(())
    }

    /// Marks `object` as the variant `index` of a task's set of objects, with that variant's
    /// `mass` (kg), `friction` and `rolling_damping` (its body's angular damping, 1/s: rapier
    /// has no rolling resistance, so without it a ball or a pear set down rolls on for ever;
    /// it also damps spinning in the air) (a task that draws its object from a set per episode, after
    /// giving it the variant's shape with [`Simulation::set_object_shape`]). The index is kept
    /// with the object's collider, so snapshots restore it; [`Simulation::object_variant`]
    /// reads it back.
    pub fn set_object_variant(
        &mut self,
        object: ObjectId,
        index: u32,
        mass: f64,
        friction: f64,
        rolling_damping: f64,
    ) -> Result<()> {
        let field = format!("scene.objects[{}]", object.0);
        positive(&format!("{field}.mass"), mass)?;
        non_negative(&format!("{field}.friction"), friction)?;
        non_negative(&format!("{field}.rolling_damping"), rolling_damping)?;
        let SceneObject { body, collider, .. } = *self.scene_object(object)?;
        if let Some(collider) = self.world.colliders.get_mut(collider) {
            collider.set_mass(mass as f32);
            collider.set_friction(friction as f32);
            collider.user_data = u128::from(index);
        }
        if let Some(body) = self.world.bodies.get_mut(body) {
            body.set_angular_damping(rolling_damping as f32);
        }
        Ok(())
    }

    /// The variant index [`Simulation::set_object_variant`] gave `object` last (0 before any,
    /// and for an id of another world's object).
    pub fn object_variant(&self, object: ObjectId) -> u32 {
        self.objects
            .get(object.0)
            .and_then(|o| self.world.colliders.get(o.collider))
            .map_or(0, |c| c.user_data as u32)
    }

    /// The shape `object` was built with (`None` for an id of another world's object).
    pub fn object_shape(&self, object: ObjectId) -> Option<&ObjectShape> {
        self.scene.objects.get(object.0).map(|o| &o.shape)
    }

    /// The half extents (m) of the smallest box aligned with `object`'s frame and centred on
    /// its origin that holds its shape as simulated now (NaN for an id of another world's
    /// object).
    pub fn object_half_extents(&self, object: ObjectId) -> Vector3<f64> {
        let collider = self.objects.get(object.0).map(|o| o.collider);
        match collider.and_then(|c| self.world.colliders.get(c)) {
            Some(c) => {
                let local = c.position_wrt_parent().copied().unwrap_or_default();
                let aabb = c.shape().compute_aabb(&local);
                vec_to_na(aabb.mins).abs().sup(&vec_to_na(aabb.maxs).abs())
            }
            None => Vector3::repeat(f64::NAN),
        }
    }

    /// Edge length (m, NaN for another shape than a cube), mass (kg) and friction of an object
    /// as simulated now (NaN for an id of another world's object).
    pub fn object_properties(&self, object: ObjectId) -> (f64, f64, f64) {
        let collider = self.objects.get(object.0).map(|o| o.collider);
        match collider.and_then(|c| self.world.colliders.get(c)) {
            Some(c) => {
                let size = c
                    .shape()
                    .as_cuboid()
                    .map(|b| b.half_extents)
                    .filter(|h| h.x == h.y && h.y == h.z)
                    .map_or(f64::NAN, |h| 2.0 * h.x as f64);
                (size, c.mass() as f64, c.friction() as f64)
            }
            None => (f64::NAN, f64::NAN, f64::NAN),
        }
    }
}

impl Simulation {
    /// The shortcut grasp of the classic PyBullet tutorial: holds `object` rigidly to the hand
    /// (the fingers' parent link), where it is relative to the hand now, by a fixed joint, until
    /// [`Simulation::detach`]. Unlike the friction grasp every environment uses, nothing has to
    /// squeeze the object and it cannot slip; it is for demonstrations of the tutorial
    /// (`TutorialSequence::grasp`), not for learning manipulation. Attaching an attached object
    /// again does nothing.
    pub fn attach(&mut self, object: ObjectId) -> Result<()> {
        let body = self.scene_object(object)?.body;
        if self.is_attached(object) {
            return Ok(());
        }
        let hand = self
            .gripper
            .as_ref()
            .and_then(|g| {
                let link = self.model.joints()[g.joint].parent_link_index;
                self.link_bodies[link]
            })
            .ok_or_else(|| Error::JointNotCommandable {
                name: "gripper".into(),
                reason: "this robot has no hand to attach objects to".into(),
            })?;
        let (Some(hand_body), Some(object_body)) =
            (self.world.bodies.get(hand), self.world.bodies.get(body))
        else {
            return Err(Error::UnknownLink {
                name: format!("object #{}", object.0),
                known: "the world's bodies".into(),
            });
        };
        let relative =
            pose_to_na(hand_body.position()).inverse() * pose_to_na(object_body.position());
        let joint = FixedJointBuilder::new()
            .local_frame1(pose_from_na(&relative))
            .contacts_enabled(false)
            .build();
        let handle = self.world.impulse_joints.insert(hand, body, joint, true);
        self.attachments.push((object, handle));
        Ok(())
    }

    /// Lets go of an object held by [`Simulation::attach`] (nothing happens if it is not).
    pub fn detach(&mut self, object: ObjectId) -> Result<()> {
        self.scene_object(object)?;
        if let Some(i) = self.attachments.iter().position(|(o, _)| *o == object) {
            let (_, handle) = self.attachments.remove(i);
            self.world.impulse_joints.remove(handle, true);
        }
        Ok(())
    }

    /// Whether `object` is held by [`Simulation::attach`].
    pub fn is_attached(&self, object: ObjectId) -> bool {
        self.attachments.iter().any(|(o, _)| *o == object)
    }
}
