//! Building a world: the floor, the scene's platform and objects, and the robot as a
//! multibody (dynamic arm) or as placed links with a gripper multibody (kinematic arm).

use nalgebra::Isometry3;
use rapier3d::dynamics::{
    CoefficientCombineRule, FixedJointBuilder, JointAxis, MultibodyDofCoupling, MultibodyIndex,
    MultibodyJointSet, RigidBodyBuilder, RigidBodyType,
};
use rapier3d::geometry::{ColliderBuilder, Group, InteractionGroups, MeshConverter};
use rapier3d::math::Vector;
use rapier3d::pipeline::PhysicsWorld;
use rapier3d_urdf::{
    UrdfColliderHandle, UrdfJoint, UrdfLinkHandle, UrdfLoaderOptions, UrdfMultibodyOptions,
    UrdfRobot,
};

use super::convert::{pose_from_na, vec_from_array};
use super::kinematic_arm::KinematicArm;
use super::touch::TouchWindow;
use super::{
    Arm, DofSlot, JointControl, Scene, SceneObject, Simulation, ARM_GROUP, OBJECT_GROUP,
    PROXIMAL_GROUP, STATIC_GROUP,
};
use crate::config::{ArmFidelity, MultibodyUpdate, SimConfig};
use crate::error::{Error, Result};
use crate::model::{JointType, RobotModel};
use crate::robot::{base_pose, home_configuration, Gripper};

impl Simulation {
    /// Builds the world described by `config` (the bundled Panda unless `robot.urdf` is set)
    /// around the classic tutorial's scene ([`Scene::tutorial`]: the platform and one cube).
    pub fn new(config: SimConfig) -> Result<Self> {
        config.validate()?;
        let model = RobotModel::from_config(&config)?;
        Self::with_model(config, model)
    }

    /// [`Simulation::new`] around an already loaded robot description.
    pub fn with_model(config: SimConfig, model: RobotModel) -> Result<Self> {
        let scene = Scene::tutorial();
        Self::with_scene(config, model, scene)
    }

    /// Builds the world of `config` with the robot `model` and the platform and objects of
    /// `scene`.
    pub fn with_scene(config: SimConfig, model: RobotModel, scene: Scene) -> Result<Self> {
        config.validate()?;
        scene.validate()?;
        let mut world = PhysicsWorld::new();
        world.gravity = vec_from_array(config.physics.gravity);
        let p = &mut world.integration_parameters;
        let s = &config.physics.solver;
        p.dt = s.dt as f32;
        p.num_solver_iterations = s.solver_iterations as usize;
        p.multibody_update = match s.multibody_update {
            MultibodyUpdate::Step => rapier3d::dynamics::MultibodyUpdate::Step,
            MultibodyUpdate::Substep => rapier3d::dynamics::MultibodyUpdate::Substep,
        };
        p.length_unit = s.length_unit as f32;
        p.normalized_prediction_distance = (s.contact_prediction_distance / s.length_unit) as f32;
        p.contact_softness.natural_frequency = s.contact_natural_frequency as f32;
        p.contact_softness.damping_ratio = s.contact_damping_ratio as f32;
        // Stale recycled contacts let the fingers "hold" the cube 7-8 mm short of touching it,
        // and without friction in the bias pass a squeezed cube creeps out of the grip.
        p.contact_recycling = false;
        p.friction_in_bias_pass = true;
        // The kinematic arm's weld between its last placed link and the gripper is an impulse
        // joint; restarting from zero impulse every substep it would sag under the load.
        p.warmstart_joints = true;

        let base = base_pose(&config);

        // Scenery.
        let floor_body = world.bodies.insert(RigidBodyBuilder::fixed().build());
        let floor_collider = world.colliders.insert_with_parent(
            ColliderBuilder::halfspace(nalgebra::Unit::new_unchecked(Vector::Z))
                .friction(
                    scene
                        .floor_friction
                        .unwrap_or(config.physics.floor_friction) as f32,
                )
                .friction_combine_rule(match scene.floor_friction {
                    Some(_) => CoefficientCombineRule::Min,
                    None => CoefficientCombineRule::Average,
                })
                .collision_groups(InteractionGroups::new(
                    STATIC_GROUP,
                    OBJECT_GROUP | ARM_GROUP,
                    Default::default(),
                ))
                .build(),
            floor_body,
            &mut world.bodies,
        );
        let platform_collider = scene.platform.as_ref().map(|pc| {
            let platform_body = world.bodies.insert(
                RigidBodyBuilder::fixed()
                    .translation(vec_from_array([
                        pc.top_center[0],
                        pc.top_center[1],
                        pc.top_center[2] - pc.size[2] / 2.0,
                    ]))
                    .build(),
            );
            world.colliders.insert_with_parent(
                ColliderBuilder::cuboid(
                    (pc.size[0] / 2.0) as f32,
                    (pc.size[1] / 2.0) as f32,
                    (pc.size[2] / 2.0) as f32,
                )
                .friction(pc.friction as f32)
                .collision_groups(InteractionGroups::new(
                    STATIC_GROUP,
                    OBJECT_GROUP | ARM_GROUP,
                    Default::default(),
                ))
                .build(),
                platform_body,
                &mut world.bodies,
            )
        });

        // The objects, in order: bodies of their shapes that collide with everything (fixtures
        // are fixed bodies; rapier never pairs two fixed bodies).
        let mut objects = Vec::with_capacity(scene.objects.len());
        for (i, spec) in scene.objects.iter().enumerate() {
            let (shape, local) = spec.shape.build(&format!("scene.objects[{i}].shape"))?;
            let builder = if spec.fixed {
                RigidBodyBuilder::fixed()
            } else {
                RigidBodyBuilder::dynamic().can_sleep(false)
            };
            let body = world
                .bodies
                .insert(builder.translation(vec_from_array(spec.position)).build());
            let collider = world.colliders.insert_with_parent(
                ColliderBuilder::new(shape)
                    .position(pose_from_na(&local))
                    .mass(spec.mass as f32)
                    .friction(spec.friction as f32)
                    .collision_groups(InteractionGroups::new(
                        OBJECT_GROUP,
                        Group::ALL,
                        Default::default(),
                    ))
                    .build(),
                body,
                &mut world.bodies,
            );
            objects.push(SceneObject {
                body,
                collider,
                fixed: spec.fixed,
            });
        }

        // The articulated objects, their roots fixed.
        let articulations = scene
            .articulations
            .iter()
            .map(|spec| super::articulation::insert_articulation(&mut world, spec))
            .collect::<Result<Vec<_>>>()?;

        // The robot, as one multibody.
        let options = UrdfLoaderOptions {
            make_roots_fixed: true,
            shift: pose_from_na(&base),
            rigid_body_blueprint: RigidBodyBuilder::dynamic().can_sleep(false),
            // Mesh colliders on moving links must be convex to collide with the cube.
            mesh_converter: Some(MeshConverter::ConvexHull),
            ..Default::default()
        };
        let gripper = Gripper::of(&model);
        let finger_joints = gripper
            .as_ref()
            .map_or(Vec::new(), |g| g.finger_joints.clone());
        let proximal = proximal_links(&model);
        let movable_joints: Vec<usize> = model
            .joints()
            .iter()
            .filter(|j| j.joint_type.is_movable())
            .map(|j| j.index)
            .collect();

        let urdf_robot = UrdfRobot::from_robot(model.urdf(), options, std::path::Path::new("/"));
        let link_sources: Vec<usize> = urdf_robot.links.iter().map(|l| l.urdf_link_index).collect();
        let (link_handles, link_sources, joint_slots, arm) = match config.arm {
            ArmFidelity::Dynamic => {
                let (handles, joint_slots, multibody) = insert_multibody(
                    &mut world,
                    urdf_robot,
                    &model,
                    &config,
                    &finger_joints,
                    |_| true,
                )?;
                (
                    handles.links,
                    link_sources,
                    joint_slots,
                    Arm::Dynamic { multibody },
                )
            }
            ArmFidelity::Kinematic => {
                let built =
                    build_kinematic_arm(&mut world, &model, &config, urdf_robot, gripper.as_ref())?;
                (
                    built.links,
                    built.link_sources,
                    built.joint_slots,
                    Arm::Kinematic {
                        gripper: built.multibody,
                        arm: built.arm,
                    },
                )
            }
        };

        let mut link_bodies = vec![None; model.links().len()];
        let mut link_friction = vec![0.0; model.links().len()];
        let mut robot_colliders = Vec::new();
        for (handle, &link) in link_handles.iter().zip(&link_sources) {
            link_bodies[link] = Some(handle.body);
            let friction = if gripper.as_ref().is_some_and(|g| g.is_finger(link)) {
                config.robot.finger_friction
            } else {
                config.robot.link_friction
            };
            link_friction[link] = friction;
            let groups = if proximal.contains(&link) {
                InteractionGroups::new(PROXIMAL_GROUP, OBJECT_GROUP, Default::default())
            } else {
                InteractionGroups::new(ARM_GROUP, OBJECT_GROUP | STATIC_GROUP, Default::default())
            };
            for c in &handle.colliders {
                if let Some(collider) = world.colliders.get_mut(c.handle) {
                    collider.set_friction(friction as f32);
                    collider.set_collision_groups(groups);
                }
                robot_colliders.push((c.handle, link));
            }
        }

        let hand_links = gripper.as_ref().map_or(Vec::new(), |g| {
            subtree(&model, model.joints()[g.joint].parent_link_index)
        });
        // Room for the hand's bodies and a few attached objects: stepping never allocates.
        let hand_capacity = hand_links.len() + 4;
        let controls = vec![JointControl::position(0.0); model.num_dofs()];
        let q0 = home_configuration(&config, &model)?;
        let mut sim = Self {
            config,
            scene,
            model,
            base,
            world,
            arm,
            gripper,
            link_bodies,
            link_friction,
            joint_slots,
            controls,
            movable_joints,
            robot_colliders,
            objects,
            articulations,
            floor_collider,
            platform_collider,
            time: 0.0,
            steps: 0,
            torques_applied: false,
            attachments: Vec::new(),
            hand_links,
            touch_window: TouchWindow::with_capacity(hand_capacity),
        };
        // rapier fills in mass properties at the first step; the wrist reading weighs the hand
        // from the start (the same values the first step computes, so nothing else changes).
        for &link in &sim.hand_links {
            if let Some(rb) = sim.link_bodies[link].and_then(|b| sim.world.bodies.get_mut(b)) {
                rb.recompute_mass_properties_from_colliders(&sim.world.colliders);
            }
        }
        sim.set_joint_positions(&q0)?;
        sim.begin_touch_window();
        Ok(sim)
    }
}

/// What [`build_kinematic_arm`] put into the world.
struct KinematicBuild {
    links: Vec<UrdfLinkHandle>,
    link_sources: Vec<usize>,
    joint_slots: Vec<Option<DofSlot>>,
    multibody: MultibodyIndex,
    arm: KinematicArm,
}

/// The kinematic arm: every link but the gripper's becomes a placed (kinematic) body; the
/// gripper (the fingers' parent link and the fingers) becomes its own multibody with the
/// dynamic arm's coupled, force-limited drive, its root free and welded by a fixed joint to
/// the placed link it hangs from. (A multibody rooted on a placed body does not pass the
/// body's motion on to the fingers' contacts, and fingers on separate impulse joints could
/// not be coupled: a held cube shuttled 1-2 cm between them during carries.)
fn build_kinematic_arm(
    world: &mut PhysicsWorld,
    model: &RobotModel,
    config: &SimConfig,
    robot: UrdfRobot,
    gripper: Option<&Gripper>,
) -> Result<KinematicBuild> {
    let malformed = |reason: &str| Error::MalformedUrdf {
        source_name: model.source().to_owned(),
        reason: reason.into(),
    };
    let gripper = gripper
        .ok_or_else(|| malformed("the kinematic arm needs a robot with a prismatic gripper"))?;
    let gripper_root = model.joints()[gripper.joint].parent_link_index;
    let finger_joints = gripper.finger_joints.as_slice();
    let in_gripper = |link: usize| {
        link == gripper_root
            || finger_joints
                .iter()
                .any(|&j| model.joints()[j].child_link_index == link)
    };
    let UrdfRobot { links, joints } = robot;
    let mut gripper_robot = UrdfRobot {
        links: Vec::new(),
        joints: Vec::new(),
    };
    let mut gripper_index = vec![None; links.len()];
    let mut placed_links = Vec::new();
    let mut link_sources = Vec::new();
    for (i, mut link) in links.into_iter().enumerate() {
        if in_gripper(link.urdf_link_index) {
            gripper_index[i] = Some(gripper_robot.links.len());
            gripper_robot.links.push(link);
        } else {
            link.body
                .set_body_type(RigidBodyType::KinematicPositionBased, false);
            let body = world.bodies.insert(link.body);
            let colliders = link
                .colliders
                .into_iter()
                .map(|c| UrdfColliderHandle {
                    handle: world
                        .colliders
                        .insert_with_parent(c.collider, body, &mut world.bodies),
                    visual: c.visual,
                })
                .collect();
            placed_links.push(UrdfLinkHandle { body, colliders });
            link_sources.push(link.urdf_link_index);
        }
    }
    for joint in joints {
        if let (Some(link1), Some(link2)) = (gripper_index[joint.link1], gripper_index[joint.link2])
        {
            gripper_robot.joints.push(UrdfJoint {
                link1,
                link2,
                ..joint
            });
        }
    }
    let gripper_sources: Vec<usize> = gripper_robot
        .links
        .iter()
        .map(|l| l.urdf_link_index)
        .collect();
    let root_position = gripper_sources
        .iter()
        .position(|&l| l == gripper_root)
        .ok_or_else(|| malformed("the gripper's parent link has no body"))?;
    let (handles, joint_slots, multibody) =
        insert_multibody(world, gripper_robot, model, config, finger_joints, |j| {
            finger_joints.contains(&j)
        })?;

    // Weld the gripper's root to the nearest placed ancestor, through fixed joints only.
    let mut offset = Isometry3::identity();
    let mut link = gripper_root;
    let anchor = loop {
        let j = model.links()[link]
            .parent_joint
            .ok_or_else(|| malformed("the gripper is the robot's root"))?;
        if model.joints()[j].joint_type != JointType::Fixed {
            return Err(malformed(
                "the kinematic arm needs the gripper fixed to the last arm link",
            ));
        }
        offset = model.joint_transform(j, 0.0) * offset;
        link = model.joints()[j].parent_link_index;
        if let Some(i) = link_sources.iter().position(|&l| l == link) {
            break placed_links[i].body;
        }
    };
    let weld = FixedJointBuilder::new()
        .local_frame1(pose_from_na(&offset))
        .contacts_enabled(false)
        .build();
    world
        .impulse_joints
        .insert(anchor, handles.links[root_position].body, weld, true);

    let mut links = placed_links;
    links.extend(handles.links);
    link_sources.extend(gripper_sources);
    Ok(KinematicBuild {
        links,
        link_sources,
        joint_slots,
        multibody,
        arm: KinematicArm::new(model),
    })
}

/// What the URDF loader returns for a robot inserted as a multibody.
type MultibodyHandles =
    rapier3d_urdf::UrdfRobotHandles<Option<rapier3d::dynamics::MultibodyJointHandle>>;

/// Inserts `robot` into `world` as a multibody (no self contacts) and finds its joints there
/// (see [`build_multibody`]; `required` says which movable joints must be in it).
fn insert_multibody(
    world: &mut PhysicsWorld,
    robot: UrdfRobot,
    model: &RobotModel,
    config: &SimConfig,
    finger_joints: &[usize],
    required: impl Fn(usize) -> bool,
) -> Result<(MultibodyHandles, Vec<Option<DofSlot>>, MultibodyIndex)> {
    let joint_sources: Vec<usize> = robot
        .joints
        .iter()
        .map(|j| j.source_urdf_joint_index())
        .collect();
    let handles = robot.insert_using_multibody_joints(
        &mut world.bodies,
        &mut world.colliders,
        &mut world.multibody_joints,
        UrdfMultibodyOptions::DISABLE_SELF_CONTACTS,
    );
    let (joint_slots, multibody) = build_multibody(
        &mut world.multibody_joints,
        model,
        config,
        &handles.joints,
        &joint_sources,
        finger_joints,
        required,
    )?;
    // rapier starts a multibody's root joint at the origin and, once it finds the root body
    // fixed, keeps that pose unless asked to read the body's: without this the dynamic arm
    // ignored `robot.base` (`sim.robot_base` then) while kinematics and `ee` control honoured
    // it (issue 33).
    if let Some(mb) = world.multibody_joints.get_multibody_mut(multibody) {
        mb.forward_kinematics(&world.bodies, true);
        mb.update_rigid_bodies(&mut world.bodies, true);
    }
    Ok((handles, joint_slots, multibody))
}

/// Where each joint of `model` landed in the multibody the URDF loader built, after giving the
/// arm's and fingers' dofs their armature and coupling the mimic joints to their masters.
fn build_multibody(
    multibody_joints: &mut MultibodyJointSet,
    model: &RobotModel,
    config: &SimConfig,
    joints: &[rapier3d_urdf::UrdfJointHandle<Option<rapier3d::dynamics::MultibodyJointHandle>>],
    joint_sources: &[usize],
    finger_joints: &[usize],
    required: impl Fn(usize) -> bool,
) -> Result<(Vec<Option<DofSlot>>, MultibodyIndex)> {
    let mut joint_slots = vec![None; model.joints().len()];
    let mut multibody = None;
    for (handle, &joint) in joints.iter().zip(joint_sources) {
        if handle.joint.is_none() {
            continue;
        }
        let Some(link_id) = multibody_joints.rigid_body_link(handle.link2).copied() else {
            continue;
        };
        multibody = Some(link_id.multibody);
        let info = &model.joints()[joint];
        let (coord, axis) = match info.joint_type {
            JointType::Prismatic => (0, JointAxis::LinX),
            JointType::Revolute | JointType::Continuous => (3, JointAxis::AngX),
            JointType::Fixed => continue,
        };
        joint_slots[joint] = Some(DofSlot {
            link_id: link_id.id,
            coord,
            axis,
            child_body: handle.link2,
            parent_body: handle.link1,
        });
    }
    for j in model.joints() {
        if j.joint_type.is_movable() && required(j.index) && joint_slots[j.index].is_none() {
            return Err(Error::MalformedUrdf {
                source_name: model.source().to_owned(),
                reason: format!("joint `{}` could not be built as a multibody joint", j.name),
            });
        }
    }
    let multibody = multibody.ok_or_else(|| Error::MalformedUrdf {
        source_name: model.source().to_owned(),
        reason: "the robot has no movable joints".into(),
    })?;

    // Mimic joints (the second finger) follow their master through a holonomic coupling,
    // like the real gripper's single drive, instead of two independently saturated motors
    // that let a held cube drift sideways.
    if let Some(mb) = multibody_joints.get_multibody_mut(multibody) {
        for j in model.joints() {
            let Some(slot) = joint_slots[j.index] else {
                continue;
            };
            let armature = if finger_joints.contains(&j.index) {
                config.robot.motors.finger_armature
            } else {
                config.robot.motors.arm_armature
            };
            // Every passive term explicit: rapier gives each angular dof a default damping of
            // 0.1 N m s/rad that no URDF or option asked for (issue 33); the URDF's
            // `<dynamics>` (0 where absent) or the configuration's override replace it.
            let damping = config.robot.joint_damping.unwrap_or(j.damping);
            let friction = config.robot.joint_friction.unwrap_or(j.friction);
            if let Some(link) = mb.link(slot.link_id) {
                let dof = link.assembly_id();
                if dof < mb.armature().len() {
                    mb.armature_mut()[dof] = armature as f32;
                    mb.damping_mut()[dof] = damping as f32;
                    mb.frictions_mut()[dof] = friction as f32;
                }
            }
        }
        for j in model.joints() {
            if let (Some(m), Some(slave)) = (j.mimic, joint_slots[j.index]) {
                if let Some(master) = joint_slots[m.master] {
                    mb.add_dof_coupling(MultibodyDofCoupling {
                        link1: master.link_id,
                        dof1: 0,
                        axis1: master.coord,
                        link2: slave.link_id,
                        dof2: 0,
                        axis2: slave.coord,
                        coeff: m.multiplier as f32,
                        offset: m.offset as f32,
                    });
                }
            }
        }
    }

    Ok((joint_slots, multibody))
}

/// Links with at most one movable joint between them and the root: they only turn about the
/// base's vertical axis and cannot reach the floor or the platform.
fn proximal_links(model: &RobotModel) -> Vec<usize> {
    model
        .links()
        .iter()
        .filter(|link| {
            let mut movable = 0;
            let mut current = link.index;
            while let Some(j) = model.links()[current].parent_joint {
                if model.joints()[j].joint_type.is_movable() {
                    movable += 1;
                }
                current = model.joints()[j].parent_link_index;
            }
            movable <= 1
        })
        .map(|l| l.index)
        .collect()
}

/// `root` and every link below it, `root` first.
fn subtree(model: &RobotModel, root: usize) -> Vec<usize> {
    let mut links = vec![root];
    let mut i = 0;
    while i < links.len() {
        let parent = links[i];
        for joint in model.joints() {
            if joint.parent_link_index == parent && !links.contains(&joint.child_link_index) {
                links.push(joint.child_link_index);
            }
        }
        i += 1;
    }
    links
}
