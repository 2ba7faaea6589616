//! Contract: third-party URDFs load too. When pybullet is installed (the test command installs
//! it in `.venv`; set `PYTHON` to use another interpreter), the reference
//! `franka_panda/panda.urdf` from `pybullet_data` loads with its `package://` meshes as convex
//! colliders, and reports the same joint names, types and limits as pybullet itself.

use std::path::{Path, PathBuf};
use std::process::Command;

use panda_rapier::{JointType, RobotModel, SimConfig, Simulation};

const MARK: &str = "PANDA_RAPIER_JSON:";

/// Asks pybullet for its data path and the joint table of its Panda; `None` without pybullet.
fn pybullet_reference() -> Option<(PathBuf, serde_json::Value)> {
    let python = std::env::var("PYTHON").unwrap_or_else(|_| {
        let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python");
        if venv.exists() {
            venv.display().to_string()
        } else {
            "python3".into()
        }
    });
    let script = format!(
        r#"
import json, os, pybullet as p, pybullet_data
path = os.path.join(pybullet_data.getDataPath(), "franka_panda", "panda.urdf")
client = p.connect(p.DIRECT)
robot = p.loadURDF(path, useFixedBase=True, physicsClientId=client)
names = {{p.JOINT_REVOLUTE: "revolute", p.JOINT_PRISMATIC: "prismatic", p.JOINT_FIXED: "fixed"}}
joints = []
for i in range(p.getNumJoints(robot, physicsClientId=client)):
    info = p.getJointInfo(robot, i, physicsClientId=client)
    joints.append(dict(name=info[1].decode(), type=names.get(info[2], str(info[2])),
                       lower=info[8], upper=info[9], max_force=info[10], max_velocity=info[11],
                       child_link=info[12].decode()))
print("{MARK}" + json.dumps(dict(path=path, joints=joints)))
"#
    );
    let output = Command::new(&python).arg("-c").arg(script).output().ok()?;
    if !output.status.success() {
        eprintln!(
            "skipped: pybullet not importable with {python}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        return None;
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let line = stdout.lines().find_map(|l| l.strip_prefix(MARK))?;
    let value: serde_json::Value = serde_json::from_str(line).ok()?;
    Some((
        PathBuf::from(value["path"].as_str()?),
        value["joints"].clone(),
    ))
}

#[test]
fn pybullet_reference_panda_loads_with_its_meshes_and_limits() {
    let Some((path, reference)) = pybullet_reference() else {
        eprintln!("skipped: pybullet is not installed");
        return;
    };
    let model = RobotModel::from_urdf_file(&path).unwrap();
    let reference = reference.as_array().unwrap();
    assert_eq!(model.joints().len(), reference.len());
    for r in reference {
        let name = r["name"].as_str().unwrap();
        let joint = &model.joints()[model.joint_index(name).unwrap()];
        let kind = match joint.joint_type {
            JointType::Revolute | JointType::Continuous => "revolute",
            JointType::Prismatic => "prismatic",
            JointType::Fixed => "fixed",
        };
        assert_eq!(kind, r["type"].as_str().unwrap(), "{name}");
        assert_eq!(
            joint.child_link,
            r["child_link"].as_str().unwrap(),
            "{name}"
        );
        if kind != "fixed" {
            for (ours, key) in [
                (joint.lower, "lower"),
                (joint.upper, "upper"),
                (joint.max_force, "max_force"),
                (joint.max_velocity, "max_velocity"),
            ] {
                let theirs = r[key].as_f64().unwrap();
                assert!(
                    (ours - theirs).abs() < 1e-9,
                    "{name}.{key}: {ours} vs pybullet {theirs}"
                );
            }
        }
    }
    // The same arm and finger joint names as the bundled Panda.
    let bundled = RobotModel::panda().unwrap();
    let movable = |m: &RobotModel| -> Vec<String> {
        m.joints()
            .iter()
            .filter(|j| j.joint_type.is_movable())
            .map(|j| j.name.clone())
            .collect()
    };
    assert_eq!(movable(&model), movable(&bundled));

    // Every link whose URDF has a collision mesh gets colliders from it, and the robot simulates.
    let mut config = SimConfig::default();
    config.robot.urdf = Some(path);
    let mut sim = Simulation::new(config).unwrap();
    for link in model
        .urdf()
        .links
        .iter()
        .filter(|l| !l.collision.is_empty())
    {
        let state = sim.link_state(&link.name).unwrap();
        assert!(state.num_colliders > 0, "{} has no collider", link.name);
    }
    for _ in 0..25 {
        sim.step_control();
    }
    assert!(sim.is_finite());
}

#[test]
fn bundled_panda_matches_pybullets_kinematics() {
    // Same joint frames as the reference description: the TCP-free link poses agree.
    let Some((path, _)) = pybullet_reference() else {
        eprintln!("skipped: pybullet is not installed");
        return;
    };
    let reference = RobotModel::from_urdf_file(&path).unwrap();
    let bundled = RobotModel::panda().unwrap();
    let q = [0.3, -0.5, 0.2, -2.0, 0.4, 1.8, 0.6, 0.02];
    let base = panda_rapier::nalgebra::Isometry3::identity();
    for link in [
        "panda_link7",
        "panda_hand",
        "panda_leftfinger",
        "panda_rightfinger",
    ] {
        let a = bundled.link_pose(link, &q, &base).unwrap();
        let b = reference.link_pose(link, &q, &base).unwrap();
        assert!(
            (a.translation.vector - b.translation.vector).norm() < 1e-6,
            "{link}"
        );
        assert!(a.rotation.angle_to(&b.rotation) < 1e-6, "{link}");
    }
}
