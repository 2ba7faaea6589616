//! How objects from files look (`ObjectVisual`): an OBJ's material colours and a URDF's
//! `<visual>` elements become coloured parts, a task that draws its object from a set draws
//! the drawn object's visual mesh in its file's colours, a mesh that is not closed is drawn
//! from both sides, and a visual mesh that cannot be read is refused by file and field.

use crate::common::obj_files;

use std::path::PathBuf;
use std::sync::Arc;

use nalgebra::{Isometry3, Vector3};
use obj_files::box_obj;
use panda_rapier::env::PandaEnv;
use panda_rapier::render::{segmentation, CameraConfig, RenderConfig, Renderer};
use panda_rapier::task::{EnvConfig, ResetOptions};
use panda_rapier::{
    Error, MeshCollision, MeshFile, ObjectShape, ObjectSpec, ObjectVisual, Scene, ShapeCache,
    SharedMesh, SimConfig, Simulation, TriangleMesh, UrdfObject, VisualPart, VisualShape,
    VisualTag,
};

fn scratch(name: &str) -> PathBuf {
    obj_files::scratch("visual_meshes", name)
}

/// Two boxes, one red and one blue by their materials (`two.mtl`).
fn two_colour_obj() -> String {
    let mut obj = String::from("mtllib two.mtl\no two\nusemtl red\n");
    box_obj(&mut obj, [-0.03, -0.02, 0.0], [0.0, 0.02, 0.04], 1);
    obj.push_str("usemtl blue\n");
    box_obj(&mut obj, [0.0, -0.02, 0.0], [0.03, 0.02, 0.04], 9);
    obj
}

const TWO_MTL: &str = "newmtl red\nKd 1 0 0\n\nnewmtl blue\nKd 0 0 1\n";

#[test]
fn an_obj_files_materials_colour_its_parts() {
    let dir = scratch("materials");
    let path = dir.join("two.obj");
    let obj = two_colour_obj();
    std::fs::write(&path, &obj).unwrap();
    let mesh = MeshFile::new(&path);
    // Without its material library: the parts, uncoloured.
    let bare = mesh.visual(obj.as_bytes(), "objects[0]").unwrap();
    assert_eq!(bare.parts.len(), 2);
    assert!(bare.parts.iter().all(|p| p.color.is_none()));
    std::fs::write(dir.join("two.mtl"), TWO_MTL).unwrap();
    let visual = mesh.visual(obj.as_bytes(), "objects[0]").unwrap();
    let colours: Vec<_> = visual.parts.iter().map(|p| p.color).collect();
    assert_eq!(colours, [Some([255, 0, 0]), Some([0, 0, 255])]);
    for part in &visual.parts {
        let VisualShape::Mesh { mesh } = &part.shape else {
            panic!("{:?}", part.shape)
        };
        assert_eq!(mesh.triangles().len(), 12);
        // The red box lies at x <= 0, the blue one at x >= 0, as the file has them.
        let red = part.color == Some([255, 0, 0]);
        assert!(mesh
            .vertices()
            .iter()
            .all(|v| if red { v.x <= 0.0 } else { v.x >= 0.0 }));
    }
    // Scaled as the collision shape is.
    let scaled = MeshFile {
        scale: [2.0; 3],
        ..MeshFile::new(&path)
    }
    .visual(obj.as_bytes(), "objects[0]")
    .unwrap();
    let VisualShape::Mesh { mesh } = &scaled.parts[0].shape else {
        panic!()
    };
    assert!(mesh.vertices().iter().any(|v| (v.x + 0.06).abs() < 1e-6));
}

#[test]
fn urdf_visuals_become_coloured_parts_and_missing_ones_are_refused() {
    let dir = scratch("urdf");
    std::fs::write(dir.join("two.obj"), two_colour_obj()).unwrap();
    std::fs::write(dir.join("two.mtl"), TWO_MTL).unwrap();
    let urdf = |visual_mesh: &str| {
        format!(
            r#"<robot name="thing">
  <material name="green"><color rgba="0 1 0 1"/></material>
  <link name="base">
    <inertial><mass value="0.2"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 0.02"/><geometry><box size="0.06 0.04 0.04"/></geometry>
      <material name="grey"><color rgba="0.5 0.5 0.5 1"/></material></visual>
    <visual><origin xyz="0 0 0.05"/><geometry><sphere radius="0.01"/></geometry>
      <material name="green"/></visual>
    <visual><geometry><mesh filename="{visual_mesh}"/></geometry>
      <material name="green"/></visual>
    <collision><origin xyz="0 0 0.02"/><geometry><box size="0.06 0.04 0.04"/></geometry></collision>
  </link>
</robot>"#
        )
    };
    let path = dir.join("thing.urdf");
    std::fs::write(&path, urdf("two.obj")).unwrap();
    let cache = ShapeCache::none();
    let object = UrdfObject::load(&path, 1.0, &MeshCollision::Hull, "objects[0]", &cache).unwrap();
    let parts = &object.visual.parts;
    assert_eq!(parts.len(), 4, "{parts:?}");
    assert!(matches!(parts[0].shape, VisualShape::Box { .. }));
    assert_eq!(parts[0].color, Some([128, 128, 128]));
    assert!((parts[0].pose.translation.z - 0.02).abs() < 1e-12);
    assert!(matches!(parts[1].shape, VisualShape::Sphere { radius } if radius == 0.01));
    // A material named and defined at the top of the file.
    assert_eq!(parts[1].color, Some([0, 255, 0]));
    // A mesh's own materials come before the element's.
    assert_eq!(parts[2].color, Some([255, 0, 0]));
    assert_eq!(parts[3].color, Some([0, 0, 255]));

    std::fs::write(&path, urdf("gone.obj")).unwrap();
    let err = UrdfObject::load(&path, 1.0, &MeshCollision::Hull, "objects[0]", &cache).unwrap_err();
    let message = err.to_string();
    assert!(matches!(err, Error::BadMesh { .. }), "{err:?}");
    for expected in ["objects[0]", "visual 2", "gone.obj", "link `base`"] {
        assert!(message.contains(expected), "{expected:?} not in {message}");
    }
}

fn pick_object_env(objects: &str) -> PandaEnv {
    let json = format!(r#"{{"task": {{"name": "pick_object", "objects": {objects}}}}}"#);
    PandaEnv::new(EnvConfig::from_json(&json).unwrap()).unwrap()
}

/// The object's primitives of `sim`.
fn object_primitives(sim: &Simulation) -> Vec<panda_rapier::VisualPrimitive> {
    let mut primitives = Vec::new();
    sim.visual_primitives(&mut primitives);
    primitives.retain(|p| p.tag == VisualTag::Object { index: 0 });
    primitives
}

/// The mean colour of the object's pixels, seen from a camera aimed at it, and their count.
fn object_colour(env: &PandaEnv) -> ([f64; 3], usize) {
    let object = env.simulation().object("object").unwrap();
    let at = env.simulation().object_state(object).position;
    let mut renderer = Renderer::new(RenderConfig {
        width: 96,
        height: 96,
        camera: CameraConfig {
            target: Some([at.x, at.y, at.z + 0.03]),
            distance: Some(0.4),
            azimuth: Some(-150.0),
            elevation: Some(40.0),
            ..CameraConfig::default()
        },
        show_goal: false,
        randomization: None,
    })
    .unwrap();
    renderer.set_segmentation(true);
    let frame = renderer.render(env);
    let (mut sum, mut count) = ([0.0; 3], 0);
    for (k, &id) in frame.segments().iter().enumerate() {
        if id == segmentation::FIRST_OBJECT {
            for (s, &c) in sum.iter_mut().zip(&frame.rgb()[3 * k..3 * k + 3]) {
                *s += f64::from(c);
            }
            count += 1;
        }
    }
    (sum.map(|s| s / count.max(1) as f64), count)
}

#[test]
fn a_drawn_object_is_drawn_as_its_visual_mesh_in_its_colours() {
    // The can is red (objects.mtl's `red`, Kd 0.75 0.12 0.10), the bowl blue (0.15 0.30 0.75).
    let mut env = pick_object_env(r#"["can", "bowl"]"#);
    let mut seen = [false; 2];
    for seed in 0..40 {
        env.reset(Some(seed), &ResetOptions::default()).unwrap();
        let sim = env.simulation();
        let variant = sim.object_variant(sim.object("object").unwrap()) as usize;
        let primitives = object_primitives(sim);
        assert!(!primitives.is_empty());
        let expected = [[191, 31, 26], [38, 77, 191]][variant];
        for p in &primitives {
            assert!(matches!(p.shape, VisualShape::Mesh { .. }), "{:?}", p.shape);
            assert_eq!(p.color, Some(expected), "variant {variant}");
        }
        if !seen[variant] {
            seen[variant] = true;
            let ([r, g, b], pixels) = object_colour(&env);
            assert!(pixels > 30, "{pixels} object pixels");
            match variant {
                0 => assert!(r > 1.8 * g && r > 1.8 * b, "the can is red: {r} {g} {b}"),
                _ => assert!(b > 1.8 * r && b > 1.5 * g, "the bowl is blue: {r} {g} {b}"),
            }
        }
        // The visual mesh moves with the body: its pose is the object's.
        let state = sim.object_state(sim.object("object").unwrap());
        assert!((primitives[0].pose.translation.vector - state.position).norm() < 1e-9);
    }
    assert_eq!(seen, [true, true]);
}

#[test]
fn a_mesh_that_is_not_closed_is_drawn_from_both_sides() {
    // One flat square (two triangles) 10 cm up, as an object's look; its collider a thin box.
    let square = TriangleMesh::new(
        vec![
            Vector3::new(-0.05, -0.05, 0.0),
            Vector3::new(0.05, -0.05, 0.0),
            Vector3::new(0.05, 0.05, 0.0),
            Vector3::new(-0.05, 0.05, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )
    .unwrap();
    let visual = ObjectVisual {
        parts: vec![VisualPart {
            shape: VisualShape::Mesh {
                mesh: SharedMesh(Arc::new(square)),
            },
            pose: Isometry3::identity(),
            color: Some([0, 200, 0]),
        }],
    };
    let scene = Scene {
        platform: None,
        objects: vec![ObjectSpec {
            name: "sheet".into(),
            shape: ObjectShape::Box {
                half_extents: [0.05, 0.05, 0.001],
            },
            mass: 0.1,
            friction: 1.0,
            position: [0.6, 0.3, 0.1],
            fixed: true,
            visuals: vec![Arc::new(visual)],
        }],
        floor_friction: None,
        articulations: Vec::new(),
    };
    let config = SimConfig::default();
    let model = panda_rapier::RobotModel::from_config(&config).unwrap();
    let sim = Simulation::with_scene(config, model, scene).unwrap();
    for elevation in [60.0, -60.0] {
        let mut renderer = Renderer::new(RenderConfig {
            width: 64,
            height: 64,
            camera: CameraConfig {
                target: Some([0.6, 0.3, 0.1]),
                distance: Some(0.4),
                azimuth: Some(30.0),
                elevation: Some(elevation),
                ..CameraConfig::default()
            },
            show_goal: false,
            randomization: None,
        })
        .unwrap();
        renderer.set_segmentation(true);
        let frame = renderer.render_simulation(&sim, &[]);
        let green = frame
            .segments()
            .iter()
            .enumerate()
            .filter(|&(k, &id)| {
                let rgb = &frame.rgb()[3 * k..3 * k + 3];
                id == segmentation::FIRST_OBJECT && rgb[1] > 2 * rgb[0].max(rgb[2]).max(10)
            })
            .count();
        assert!(
            green > 200,
            "{green} green pixels from elevation {elevation}"
        );
    }
}
