//! `ee_pose` control (issue 58): the 7-D action turns the hand as well as moving it, in the base
//! or the hand frame; bad values are refused with the option's name (that results are the same
//! bits for any thread count is `tests/integration/env_determinism.rs`'s contract). Seeds 5801-5809 are this file's own.

use nalgebra::{UnitQuaternion, Vector3};
use panda_rapier::env::{EeFrame, PandaEnv};
use panda_rapier::task::{ControlMode, EnvConfig, ResetOptions};
use panda_rapier::Error;

fn pose_config(frame: EeFrame) -> EnvConfig {
    EnvConfig {
        control_mode: ControlMode::EePose,
        ee_frame: frame,
        max_episode_steps: None,
        ..EnvConfig::default()
    }
}

/// Steers the TCP to `goal` (orientation) at `position` with `ee_pose` actions for `steps`
/// steps, each action the remaining error scaled by the steps (clipped to `[-1, 1]`), in
/// `frame`. Returns the final TCP pose.
fn steer(
    env: &mut PandaEnv,
    position: Vector3<f64>,
    goal: UnitQuaternion<f64>,
    steps: usize,
) -> (Vector3<f64>, UnitQuaternion<f64>) {
    let config = env.config().clone();
    for _ in 0..steps {
        let tcp = env.simulation().tcp_state();
        let (dp, dr) = match config.ee_frame {
            EeFrame::Base => (
                position - tcp.position,
                (goal * tcp.orientation.inverse()).scaled_axis(),
            ),
            EeFrame::Hand => (
                tcp.orientation.inverse() * (position - tcp.position),
                (tcp.orientation.inverse() * goal).scaled_axis(),
            ),
        };
        let mut action = [0.0f32; 7];
        for i in 0..3 {
            action[i] = (dp[i] / config.ee_step).clamp(-1.0, 1.0) as f32;
            action[i + 3] = (dr[i] / config.ee_rot_step).clamp(-1.0, 1.0) as f32;
        }
        action[6] = 1.0;
        env.step(&action).unwrap();
    }
    let tcp = env.simulation().tcp_state();
    (tcp.position, tcp.orientation)
}

/// A commanded rotation is reached within 0.02 rad, the TCP held within 5 mm, in 30 steps
/// (1.2 s): a yaw of 0.6 rad and a tilt of 0.4 rad about the base's y axis, and a roll of
/// 0.4 rad about the hand's own x axis.
#[test]
fn pose_actions_turn_the_hand_to_the_commanded_orientation() {
    let cases = [
        (EeFrame::Base, Vector3::z() * 0.6, 5801),
        (EeFrame::Base, Vector3::y() * 0.4, 5802),
        (EeFrame::Hand, Vector3::x() * 0.4, 5803),
    ];
    for (frame, turn, seed) in cases {
        let mut env = PandaEnv::new(pose_config(frame)).unwrap();
        env.reset(Some(seed), &ResetOptions::default()).unwrap();
        let start = env.simulation().tcp_state();
        let turn = UnitQuaternion::from_scaled_axis(turn);
        let goal = match frame {
            EeFrame::Base => turn * start.orientation,
            EeFrame::Hand => start.orientation * turn,
        };
        let (position, orientation) = steer(&mut env, start.position, goal, 30);
        let angle = orientation.angle_to(&goal);
        let drift = (position - start.position).norm();
        assert!(
            angle < 0.02,
            "{frame:?} {turn:?}: {angle} rad from the goal"
        );
        assert!(drift < 0.005, "{frame:?} {turn:?}: the TCP moved {drift} m");
    }
}

/// `ee_pose` actions move the TCP like the same `ee` actions (within 5 mm after 10 steps of
/// 0.042 m), and a zero rotation keeps the hand's orientation within 0.1 rad (measured:
/// 0.064 rad): each step's goal is the measured orientation, which trails the arm's motion a
/// little, so it drifts on fast moves where `ee` holds the hand down absolutely. A policy that
/// must hold an orientation feeds its error back, as `steer` does above.
#[test]
fn a_pose_action_without_rotation_moves_the_hand_like_ee_control() {
    let mut ee = PandaEnv::new(EnvConfig::default()).unwrap();
    let mut pose = PandaEnv::new(pose_config(EeFrame::Base)).unwrap();
    ee.reset(Some(5804), &ResetOptions::default()).unwrap();
    pose.reset(Some(5804), &ResetOptions::default()).unwrap();
    let start = pose.simulation().tcp_state().orientation;
    for _ in 0..10 {
        ee.step(&[0.0, 0.6, -0.6, 1.0]).unwrap();
        pose.step(&[0.0, 0.6, -0.6, 0.0, 0.0, 0.0, 1.0]).unwrap();
    }
    let (a, b) = (ee.simulation().tcp_state(), pose.simulation().tcp_state());
    assert!((a.position - b.position).norm() < 0.005, "{a:?} vs {b:?}");
    let turned = b.orientation.angle_to(&start);
    assert!(turned < 0.1, "the hand turned {turned} rad");
}

#[test]
fn bad_pose_inputs_are_refused_with_their_names() {
    let mut env = PandaEnv::new(pose_config(EeFrame::Base)).unwrap();
    assert_eq!(env.action_dim(), 7);
    env.reset(Some(5805), &ResetOptions::default()).unwrap();
    let mut action = [0.0f32; 7];
    action[4] = f32::NAN;
    match env.step(&action) {
        Err(Error::InvalidAction { what, .. }) => assert_eq!(what, "action[4]"),
        other => panic!("{other:?}"),
    }
    match env.step(&[0.0; 4]) {
        Err(Error::InvalidAction { reason, .. }) => assert!(reason.contains('7'), "{reason}"),
        other => panic!("{other:?}"),
    }
    let cases = [
        (
            r#"{"control_mode": "ee_pose", "ee_frame": "tool"}"#,
            "ee_frame",
        ),
        (r#"{"control_mode": "ee_pose", "ee_frame": 1}"#, "ee_frame"),
        (
            r#"{"control_mode": "ee_pose", "ee_rot_step": 0.0}"#,
            "ee_rot_step",
        ),
        (
            r#"{"control_mode": "ee_pose", "ee_rot_step": -0.1}"#,
            "ee_rot_step",
        ),
    ];
    for (json, option) in cases {
        match EnvConfig::from_json(json) {
            Err(Error::InvalidConfig { field, .. }) => assert_eq!(field, option, "{json}"),
            other => panic!("{json}: {other:?}"),
        }
    }
}
