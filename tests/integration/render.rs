//! Rendering contract: the physics module describes every collider for drawing, the CPU
//! renderer draws the cube and the robot where they are, and the same state gives the same
//! bytes.

use panda_rapier::env::PandaEnv;
use panda_rapier::render::{CameraConfig, RenderConfig, Renderer};
use panda_rapier::task::{EnvConfig, ResetOptions};
use panda_rapier::{SimConfig, Simulation, VisualShape, VisualTag};

fn env(seed: u64) -> PandaEnv {
    let mut env = PandaEnv::new(EnvConfig::default()).unwrap();
    env.reset(Some(seed), &ResetOptions::default()).unwrap();
    env
}

fn renderer(width: u32, height: u32) -> Renderer {
    Renderer::new(RenderConfig {
        width,
        height,
        camera: CameraConfig::default(),
        show_goal: true,
        randomization: None,
    })
    .unwrap()
}

fn is_cube_colour([r, g, b]: [u8; 3]) -> bool {
    r > 100 && u16::from(r) > 2 * u16::from(g) && u16::from(r) > 2 * u16::from(b)
}

#[test]
fn visual_primitives_describe_every_collider_at_its_pose() {
    let sim = Simulation::new(SimConfig::default()).unwrap();
    let mut primitives = Vec::new();
    sim.visual_primitives(&mut primitives);
    let count = |f: &dyn Fn(&VisualTag) -> bool| primitives.iter().filter(|p| f(&p.tag)).count();
    assert_eq!(count(&|t| *t == VisualTag::Floor), 1);
    assert_eq!(count(&|t| *t == VisualTag::Platform), 1);
    assert_eq!(count(&|t| *t == VisualTag::Object { index: 0 }), 1);
    let robot: usize = sim.link_states().iter().map(|l| l.num_colliders).sum();
    assert_eq!(count(&|t| matches!(t, VisualTag::RobotLink { .. })), robot);
    assert!(count(&|t| matches!(t, VisualTag::RobotLink { finger: true, .. })) >= 2);
    let cube = primitives
        .iter()
        .find(|p| p.tag == VisualTag::Object { index: 0 })
        .unwrap();
    assert!(
        (cube.pose.translation.vector - sim.object_state(sim.object("cube").unwrap()).position)
            .norm()
            < 1e-6
    );
    let half = sim.scene().objects[0].shape.cube_size().unwrap() / 2.0;
    assert!(
        matches!(cube.shape, VisualShape::Box { half_extents } if (half_extents.x - half).abs() < 1e-6)
    );
    // The Panda's links are capsules, cylinders and boxes, and every pose is finite.
    assert!(primitives
        .iter()
        .any(|p| matches!(p.shape, VisualShape::Capsule { .. })));
    assert!(primitives
        .iter()
        .any(|p| matches!(p.shape, VisualShape::Cylinder { .. })));
    for p in &primitives {
        assert!(p.pose.translation.vector.iter().all(|x| x.is_finite()));
    }
}

#[test]
fn the_cube_is_drawn_where_it_is() {
    let env = env(7);
    let mut renderer = renderer(480, 320);
    let cube = env
        .simulation()
        .object_state(env.simulation().object("cube").unwrap())
        .position;
    let [x, y] = renderer.camera().project(&cube, 480, 320).unwrap();
    let frame = renderer.render(&env);
    let (x, y) = (x as u32, y as u32);
    for (dx, dy) in [(0, 0), (2, 0), (0, 2)] {
        assert!(
            is_cube_colour(frame.pixel(x + dx, y + dy)),
            "{:?}",
            frame.pixel(x + dx, y + dy)
        );
    }
    // And only there: no other red in the scene.
    let mut far = 0;
    for py in 0..320 {
        for px in 0..480 {
            if is_cube_colour(frame.pixel(px, py)) && (px.abs_diff(x) > 40 || py.abs_diff(y) > 40) {
                far += 1;
            }
        }
    }
    assert_eq!(far, 0);
}

#[test]
fn moving_the_arm_changes_the_picture_near_the_hand() {
    let mut env = env(2);
    let mut renderer = renderer(320, 240);
    let before = renderer.render(&env).clone();
    let hand = env.simulation().tcp_state().position;
    let action = [1.0, 0.0, 0.0, 1.0]; // 5 cm forward per step
    for _ in 0..4 {
        env.step(&action).unwrap();
    }
    let after = renderer.render(&env).clone();
    let [x, y] = renderer.camera().project(&hand, 320, 240).unwrap();
    let mut changed_near_hand = 0;
    for py in (y as u32).saturating_sub(15)..(y as u32 + 15).min(240) {
        for px in (x as u32).saturating_sub(15)..(x as u32 + 15).min(320) {
            changed_near_hand += usize::from(before.pixel(px, py) != after.pixel(px, py));
        }
    }
    assert!(changed_near_hand > 50, "{changed_near_hand}");
}

#[test]
fn the_same_state_gives_the_same_bytes() {
    let (mut a, mut b) = (env(11), env(11));
    for _ in 0..10 {
        a.step(&[0.3, -0.2, -0.5, 0.0]).unwrap();
        b.step(&[0.3, -0.2, -0.5, 0.0]).unwrap();
    }
    let (mut ra, mut rb) = (renderer(200, 150), renderer(200, 150));
    let first = ra.render(&a).rgb().to_vec();
    assert_eq!(first, rb.render(&b).rgb());
    // A reused renderer leaves nothing of the previous picture behind.
    ra.render(&env(3));
    assert_eq!(first, ra.render(&a).rgb());
}

#[test]
fn unusual_cameras_draw_without_panicking() {
    let env = env(0);
    for camera in [
        CameraConfig {
            elevation: Some(90.0),
            ..Default::default()
        },
        CameraConfig {
            elevation: Some(-90.0),
            ..Default::default()
        },
        // Inside the platform and right at the floor: everything is clipped at the near plane.
        CameraConfig {
            eye: Some([0.5, 0.3, 0.05]),
            ..Default::default()
        },
        CameraConfig {
            eye: Some([0.5, -0.15, 0.0]),
            target: Some([0.0, 0.0, 0.0]),
            fov: Some(170.0),
            ..Default::default()
        },
    ] {
        let mut r = Renderer::new(RenderConfig {
            width: 64,
            height: 48,
            camera,
            show_goal: true,
            randomization: None,
        })
        .unwrap();
        assert_eq!(r.render(&env).rgb().len(), 64 * 48 * 3);
    }
}

#[test]
fn a_reset_is_drawn_before_any_step() {
    // Resets teleport the cube; the picture must show it where the observation says.
    let env = env(5);
    let mut primitives = Vec::new();
    env.simulation().visual_primitives(&mut primitives);
    let cube = primitives
        .iter()
        .find(|p| p.tag == VisualTag::Object { index: 0 })
        .unwrap();
    let observed = &env.observation()[env.layout().achieved_goal()];
    for (drawn, seen) in cube.pose.translation.vector.iter().zip(observed) {
        assert!((drawn - f64::from(*seen)).abs() < 1e-6);
    }
}

#[test]
fn a_renderer_draws_each_scene_as_a_fresh_one_would() {
    // The renderer caches each primitive's triangles: drawing another scene in between (more
    // objects, no platform) must not change what it draws for the first.
    let stack_config = EnvConfig {
        task: panda_rapier::task::TaskKind::Stack.into(),
        ..EnvConfig::default()
    };
    let mut stack = PandaEnv::new(stack_config).unwrap();
    stack.reset(Some(4), &ResetOptions::default()).unwrap();
    let lift_config = EnvConfig {
        task: panda_rapier::task::TaskKind::Lift.into(),
        ..EnvConfig::default()
    };
    let mut lift = PandaEnv::new(lift_config).unwrap();
    lift.reset(Some(4), &ResetOptions::default()).unwrap();
    let pick = env(4);
    for (width, height) in [(84, 84), (320, 240)] {
        let mut shared = renderer(width, height);
        for scene in [&pick, &stack, &lift, &pick, &stack] {
            let drawn = shared.render(scene).rgb().to_vec();
            let fresh = renderer(width, height).render(scene).rgb().to_vec();
            assert_eq!(drawn, fresh, "{width}x{height}");
        }
    }
}
