//! Objects of every [`ObjectShape`] and fixtures: they fall, settle and then rest without
//! drifting or sinking; a fixture stays where it is put and holds what falls into it; snapshots
//! restore them bit for bit; renderers see every part; bad shapes are refused by name.

use crate::common::objects;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use objects::{object, run, world};
use panda_rapier::{
    Error, ObjectId, ObjectShape, RobotModel, Scene, ShapePart, SimConfig, Simulation, VisualShape,
    VisualTag,
};

/// A box of outer size `outer` x `outer` x `height` on the floor with a square hole of side
/// `hole` through it along z, as four walls.
fn box_with_hole(outer: f64, hole: f64, height: f64) -> ObjectShape {
    let wall = (outer - hole) / 2.0;
    let offset = (hole + wall) / 2.0;
    let along_x = ObjectShape::Box {
        half_extents: [outer / 2.0, wall / 2.0, height / 2.0],
    };
    let along_y = ObjectShape::Box {
        half_extents: [wall / 2.0, hole / 2.0, height / 2.0],
    };
    ObjectShape::Compound {
        parts: vec![
            ShapePart::at([0.0, offset, 0.0], along_x.clone()),
            ShapePart::at([0.0, -offset, 0.0], along_x),
            ShapePart::at([offset, 0.0, 0.0], along_y.clone()),
            ShapePart::at([-offset, 0.0, 0.0], along_y),
        ],
    }
}

/// An L of two boxes.
fn ell() -> ObjectShape {
    ObjectShape::Compound {
        parts: vec![
            ShapePart::at(
                [0.0, 0.0, 0.0],
                ObjectShape::Box {
                    half_extents: [0.04, 0.01, 0.01],
                },
            ),
            ShapePart::at(
                [0.03, 0.03, 0.0],
                ObjectShape::Box {
                    half_extents: [0.01, 0.02, 0.01],
                },
            ),
        ],
    }
}

/// A wedge: a prism over a right triangle (legs `a` along x and y), `2 h` high, as the hull
/// of its six corners and a point inside.
fn wedge(a: f64, h: f64) -> ObjectShape {
    let mut points = vec![[a / 4.0, a / 4.0, 0.0]];
    for z in [-h, h] {
        points.extend([
            [-a / 2.0, -a / 2.0, z],
            [a / 2.0, -a / 2.0, z],
            [-a / 2.0, a / 2.0, z],
        ]);
    }
    ObjectShape::ConvexHull { points }
}

/// Every shape once, away from the arm, 5 cm above where each rests; and a fixture.
fn scene() -> Scene {
    let mut fixture = object(
        "fixture",
        box_with_hole(0.12, 0.06, 0.05),
        [0.45, -0.35, 0.025],
    );
    fixture.fixed = true;
    Scene {
        platform: None,
        objects: vec![
            object(
                "slab",
                ObjectShape::Box {
                    half_extents: [0.04, 0.02, 0.01],
                },
                [0.5, 0.3, 0.06],
            ),
            object(
                "can",
                ObjectShape::Cylinder {
                    radius: 0.03,
                    half_height: 0.05,
                },
                [0.6, 0.45, 0.1],
            ),
            object(
                "pill",
                ObjectShape::Capsule {
                    radius: 0.02,
                    half_height: 0.03,
                },
                [0.4, 0.45, 0.1],
            ),
            object(
                "ball",
                ObjectShape::Sphere { radius: 0.03 },
                [0.7, 0.3, 0.08],
            ),
            object("hull", wedge(0.06, 0.02), [0.3, 0.3, 0.07]),
            object("ell", ell(), [0.6, 0.15, 0.06]),
            fixture,
            // Falls into the fixture's hole (2 cm of clearance on each side).
            object("peg", ObjectShape::cube(0.02), [0.45, -0.35, 0.15]),
        ],
        floor_friction: None,
        articulations: Vec::new(),
    }
}

fn ids(sim: &Simulation) -> Vec<ObjectId> {
    sim.object_ids().collect()
}

#[test]
fn objects_of_every_shape_settle_and_rest_without_drift_or_sinking() {
    let mut sim = world(scene());
    // The capsule lies on its side.
    let pill = sim.object("pill").unwrap();
    let lying = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
    sim.set_object_pose(pill, &Vector3::new(0.4, 0.45, 0.07), &lying)
        .unwrap();
    run(&mut sim, 2.0);
    let settled: Vec<_> = ids(&sim).iter().map(|&o| sim.object_state(o)).collect();
    run(&mut sim, 2.0);
    // The lowest point of each dynamic shape as it lies: half its height.
    let expected_z = [
        ("slab", 0.01),
        ("can", 0.05),
        ("pill", 0.02),
        ("ball", 0.03),
        ("hull", 0.02),
        ("ell", 0.01),
        ("fixture", 0.025),
        ("peg", 0.01),
    ];
    for (&o, before) in ids(&sim).iter().zip(&settled) {
        let (name, z) = expected_z[o.index()];
        assert_eq!(sim.object(name).unwrap(), o);
        let now = sim.object_state(o);
        let drift = (now.position - before.position).norm();
        assert!(drift < 1e-3, "{name} drifted {drift} m in 2 s");
        assert!(
            (now.position.z - z).abs() < 1e-3,
            "{name} rests at z = {} instead of {z}",
            now.position.z
        );
        assert!(now.linear_velocity.norm() < 1e-3, "{name} still moves");
    }
    // The fixture did not move at all (but for f32 rounding), and the cube fell through its
    // hole onto the floor.
    let fixture = sim.object_state(sim.object("fixture").unwrap());
    assert!((fixture.position - Vector3::new(0.45, -0.35, 0.025)).norm() < 1e-7);
    let peg = sim.object_state(sim.object("peg").unwrap()).position;
    assert!(
        (peg.xy() - Vector3::new(0.45, -0.35, 0.0).xy()).norm() < 0.021,
        "{peg}"
    );
}

#[test]
fn a_fixture_moves_only_when_set_and_holds_a_peg_in_its_hole() {
    let mut sim = world(scene());
    let fixture = sim.object("fixture").unwrap();
    let peg = sim.object("peg").unwrap();
    let turned = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.4);
    sim.set_object_pose(fixture, &Vector3::new(0.5, -0.3, 0.025), &turned)
        .unwrap();
    sim.set_object_pose(peg, &Vector3::new(0.5, -0.3, 0.2), &turned)
        .unwrap();
    run(&mut sim, 1.5);
    let f = sim.object_state(fixture);
    assert!((f.position - Vector3::new(0.5, -0.3, 0.025)).norm() < 1e-7);
    assert!(f.orientation.angle_to(&turned) < 1e-6);
    let p = sim.object_state(peg).position;
    assert!((p - Vector3::new(0.5, -0.3, 0.01)).norm() < 2.2e-2, "{p}");
    // Dropped onto a wall, the peg lands on its top (5 cm up), not inside it.
    let wall = turned * Vector3::new(0.0, 0.045, 0.0) + Vector3::new(0.5, -0.3, 0.0);
    sim.set_object_pose(peg, &(wall + Vector3::new(0.0, 0.0, 0.2)), &turned)
        .unwrap();
    run(&mut sim, 1.5);
    let p = sim.object_state(peg).position;
    assert!((p.z - 0.06).abs() < 2e-3, "{p}");
}

#[test]
fn snapshots_restore_every_shape_bit_for_bit() {
    let mut sim = world(scene());
    run(&mut sim, 0.3);
    let snapshot = sim.snapshot();
    run(&mut sim, 0.5);
    let first: Vec<_> = ids(&sim).iter().map(|&o| sim.object_state(o)).collect();
    sim.restore(&snapshot).unwrap();
    run(&mut sim, 0.5);
    let second: Vec<_> = ids(&sim).iter().map(|&o| sim.object_state(o)).collect();
    assert_eq!(first, second);
    let again = {
        let mut sim = world(scene());
        run(&mut sim, 0.8);
        ids(&sim)
            .iter()
            .map(|&o| sim.object_state(o))
            .collect::<Vec<_>>()
    };
    assert_eq!(first, again);
}

#[test]
fn renderers_see_every_part_and_extents_match_the_shapes() {
    let sim = world(scene());
    let mut visuals = Vec::new();
    sim.visual_primitives(&mut visuals);
    let of = |index: usize| {
        visuals
            .iter()
            .filter(move |v| v.tag == VisualTag::Object { index })
            .collect::<Vec<_>>()
    };
    let names: Vec<_> = sim.scene().objects.iter().map(|o| o.name.clone()).collect();
    let index = |name: &str| names.iter().position(|n| n == name).unwrap();
    assert_eq!(of(index("fixture")).len(), 4);
    assert_eq!(of(index("ell")).len(), 2);
    assert!(matches!(
        of(index("can"))[0].shape,
        VisualShape::Cylinder { .. }
    ));
    assert!(matches!(
        of(index("pill"))[0].shape,
        VisualShape::Capsule { .. }
    ));
    assert!(matches!(
        of(index("hull"))[0].shape,
        VisualShape::ConvexMesh { .. }
    ));
    // The can's visual axis is the object's z axis: its visual frame's z points up.
    let can = of(index("can"))[0];
    let axis = can.pose.rotation * Vector3::z();
    assert!((axis - Vector3::z()).norm() < 1e-6, "{axis}");
    for (o, spec) in ids(&sim).into_iter().zip(&sim.scene().objects) {
        let simulated = sim.object_half_extents(o);
        let described = spec.shape.half_extents();
        assert!(
            (simulated - described).norm() < 1e-6,
            "{}: {simulated} vs {described}",
            spec.name
        );
    }
    let slab = sim.object("slab").unwrap();
    assert!(sim.object_properties(slab).0.is_nan());
    assert_eq!(sim.object_shape(slab), Some(&scene().objects[0].shape));
}

#[test]
fn bad_shapes_are_refused_by_name() {
    let build = |scene: Scene| {
        let config = SimConfig::default();
        let model = RobotModel::from_config(&config).unwrap();
        Simulation::with_scene(config, model, scene).err()
    };
    let with = |shape: ObjectShape| {
        let mut scene = scene();
        scene.objects[2].shape = shape;
        build(scene)
    };
    let field = |err: Option<Error>| match err {
        Some(Error::InvalidConfig { field, .. }) => field,
        Some(Error::NonFinite { what, .. }) => what,
        other => panic!("expected an invalid configuration, got {other:?}"),
    };
    assert_eq!(
        field(with(ObjectShape::Capsule {
            radius: -0.01,
            half_height: 0.02
        })),
        "scene.objects[2].shape.radius"
    );
    assert_eq!(
        field(with(ObjectShape::ConvexHull {
            points: vec![
                [0.0, 0.0, 0.0],
                [0.1, 0.0, 0.0],
                [0.0, 0.1, 0.0],
                [0.1, 0.1, 0.0]
            ],
        })),
        "scene.objects[2].shape.points"
    );
    assert_eq!(
        field(with(ObjectShape::ConvexHull {
            points: vec![[0.0, f64::NAN, 0.0]; 4],
        })),
        "scene.objects[2].shape.points[0][1]"
    );
    assert_eq!(
        field(with(ObjectShape::Compound {
            parts: vec![ShapePart {
                pose: Isometry3::translation(f64::INFINITY, 0.0, 0.0),
                shape: ObjectShape::cube(0.02),
            }],
        })),
        "scene.objects[2].shape.parts[0].pose.translation[0]"
    );
    // Only a cube's size can be randomised.
    let mut sim = world(scene());
    let slab = sim.object("slab").unwrap();
    let err = sim.set_object_properties(slab, 0.05, 0.1, 0.5).unwrap_err();
    assert!(err.to_string().contains("slab"), "{err}");
    let peg = sim.object("peg").unwrap();
    sim.set_object_properties(peg, 0.03, 0.1, 0.5).unwrap();
    assert!((sim.object_properties(peg).0 - 0.03).abs() < 1e-7);
}

#[test]
fn an_object_given_another_shape_collides_renders_and_restores_as_it() {
    let mut sim = world(scene());
    let slab = sim.object("slab").unwrap();
    let before = sim.snapshot();
    // A taller bar: it rests on the floor 3 cm up instead of 1 cm.
    let bar = ObjectShape::Box {
        half_extents: [0.05, 0.015, 0.03],
    };
    sim.set_object_shape(slab, &bar).unwrap();
    let mass = sim.object_properties(slab).1;
    sim.set_object_pose(
        slab,
        &Vector3::new(0.5, 0.3, 0.08),
        &UnitQuaternion::identity(),
    )
    .unwrap();
    run(&mut sim, 1.5);
    let z = sim.object_state(slab).position.z;
    assert!((z - 0.03).abs() < 1e-3, "{z}");
    assert!((sim.object_half_extents(slab) - Vector3::new(0.05, 0.015, 0.03)).norm() < 1e-6);
    assert_eq!(mass, 0.1f32 as f64, "the mass is kept");
    let mut visuals = Vec::new();
    sim.visual_primitives(&mut visuals);
    let drawn = visuals
        .iter()
        .find(|v| {
            v.tag
                == VisualTag::Object {
                    index: slab.index(),
                }
        })
        .unwrap();
    match drawn.shape {
        VisualShape::Box { half_extents } => {
            assert!((half_extents - Vector3::new(0.05, 0.015, 0.03)).norm() < 1e-6)
        }
        ref other => panic!("{other:?}"),
    }
    // The spec keeps the shape the world was built with; a snapshot from before restores the
    // old shape, one from after the new.
    assert_eq!(sim.object_shape(slab), Some(&scene().objects[0].shape));
    let after = sim.snapshot();
    sim.restore(&before).unwrap();
    assert!((sim.object_half_extents(slab) - Vector3::new(0.04, 0.02, 0.01)).norm() < 1e-6);
    sim.restore(&after).unwrap();
    assert!((sim.object_half_extents(slab) - Vector3::new(0.05, 0.015, 0.03)).norm() < 1e-6);
    // Bad shapes are refused by name, and the object keeps its shape.
    match sim.set_object_shape(slab, &ObjectShape::Sphere { radius: -1.0 }) {
        Err(Error::InvalidConfig { field, .. }) => {
            assert!(field.starts_with("scene.objects[0].shape"), "{field}")
        }
        other => panic!("{other:?}"),
    }
    assert!((sim.object_half_extents(slab) - Vector3::new(0.05, 0.015, 0.03)).norm() < 1e-6);
}

#[test]
fn a_resting_object_presses_on_another_with_its_weight_and_barely_sinks_in() {
    let mut sim = world(scene());
    let fixture = sim.object("fixture").unwrap();
    let slab = sim.object("slab").unwrap();
    // The slab (0.1 kg) lies across the fixture's top, 5 cm up (the cube that falls into the
    // fixture is put aside).
    let cube = sim.object("peg").unwrap();
    sim.set_object_pose(
        cube,
        &Vector3::new(0.3, -0.2, 0.01),
        &UnitQuaternion::identity(),
    )
    .unwrap();
    sim.set_object_pose(
        slab,
        &Vector3::new(0.45, -0.35, 0.07),
        &UnitQuaternion::identity(),
    )
    .unwrap();
    run(&mut sim, 1.5);
    let contact = sim.contact_between(slab, fixture);
    assert_eq!(contact, sim.contact_between(fixture, slab));
    assert!(contact.points > 0);
    let weight = 0.1 * 9.81;
    assert!(
        (contact.normal_force - weight).abs() < 0.05 * weight,
        "{contact:?}"
    );
    assert!(contact.penetration < 2e-3, "{contact:?}");
    // Apart: nothing.
    let ball = sim.object("ball").unwrap();
    assert_eq!(
        sim.contact_between(slab, ball),
        panda_rapier::PairContact::default()
    );
}

/// A prism over a regular polygon of `sides` corners (circumradius `r`, `2 h` high) along z,
/// as the convex hull of its corners, optionally wider at the top (a frustum, as a bowl's or a
/// cup's hull is).
fn prism(sides: usize, r: f64, top_r: f64, h: f64) -> ObjectShape {
    let mut points = Vec::new();
    for k in 0..sides {
        let a = k as f64 * std::f64::consts::TAU / sides as f64 + 0.1;
        points.push([r * a.cos(), r * a.sin(), -h]);
        points.push([top_r * a.cos(), top_r * a.sin(), h]);
    }
    ObjectShape::ConvexHull { points }
}

#[test]
fn hulls_with_faces_of_many_corners_rest_on_them() {
    // Hulls whose base is one flat face of 5 to 32 corners (cans, bottles, bowls and cups
    // from meshes have such faces). Before our parry patch (patches/parry3d/) a face touched
    // the floor at its first four corners only: the hexagonal prism tipped over within 1 s
    // and the 12-sided one rolled away and sank 2.5 mm into the floor.
    let shapes = [
        ("pentagon", prism(5, 0.03, 0.03, 0.02)),
        ("hexagon", prism(6, 0.03, 0.03, 0.02)),
        ("octagon", prism(8, 0.03, 0.03, 0.02)),
        ("12-gon", prism(12, 0.03, 0.03, 0.02)),
        ("32-gon can", prism(32, 0.033, 0.033, 0.06)),
        ("16-gon cup", prism(16, 0.025, 0.04, 0.04)),
    ];
    // Each base 1 cm above the floor, away from the arm.
    let objects = shapes
        .iter()
        .enumerate()
        .map(|(i, (name, shape))| {
            let ObjectShape::ConvexHull { points } = shape else {
                unreachable!()
            };
            let h = points.iter().map(|p| p[2]).fold(0.0, f64::max);
            let (x, y) = (0.35 + 0.1 * (i % 3) as f64, 0.3 + 0.15 * (i / 3) as f64);
            object(name, shape.clone(), [x, y, h + 0.01])
        })
        .collect();
    let mut sim = world(Scene {
        platform: None,
        objects,
        floor_friction: None,
        articulations: Vec::new(),
    });
    run(&mut sim, 1.5);
    let settled: Vec<_> = ids(&sim).iter().map(|&o| sim.object_state(o)).collect();
    run(&mut sim, 2.0);
    for ((&o, before), (name, _)) in ids(&sim).iter().zip(&settled).zip(&shapes) {
        let now = sim.object_state(o);
        let tilt = now.orientation.angle_to(&UnitQuaternion::identity());
        assert!(tilt < 0.01, "{name} tipped over: tilted {tilt} rad");
        let drift = (now.position - before.position).norm();
        assert!(drift < 1e-3, "{name} drifted {drift} m in 2 s");
        // The hull's lowest point (its base) on the floor, within 1 mm.
        let Some(ObjectShape::ConvexHull { points }) = sim.object_shape(o) else {
            unreachable!("{name} is a hull")
        };
        let lowest = points
            .iter()
            .map(|&p| (now.orientation * Vector3::from(p) + now.position).z)
            .fold(f64::INFINITY, f64::min);
        assert!(lowest.abs() < 1e-3, "{name}'s base rests at z = {lowest}");
        assert!(now.linear_velocity.norm() < 1e-3, "{name} still moves");
    }
}
