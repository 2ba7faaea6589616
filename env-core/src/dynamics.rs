//! Rigid-body dynamics of the robot model as pure functions of the state: inverse dynamics,
//! gravity torques, the joint-space mass matrix and Jacobians (what PyBullet users know as
//! `calculateInverseDynamics`, `calculateMassMatrix` and `calculateJacobian`).
//!
//! Computed from the URDF's `<inertial>` blocks by the recursive Newton-Euler algorithm in world
//! coordinates, in f64, independently of the physics engine: a reference the simulation is
//! tested against (and MuJoCo against both, `tests/python/test_dynamics.py`). Generalised
//! coordinates are the entries of `q` (the actuated joints; a mimic joint moves with its
//! master, so the gripper's two fingers are one entry). Passive terms of the simulation
//! (joint damping and friction, armature) are not part of these rigid-body quantities.

use nalgebra::{DMatrix, Isometry3, Matrix3, Vector3};

use crate::error::{Error, Result};
use crate::model::{urdf_pose, JointType, RobotModel};

/// A link's mass, centre of mass (link frame) and inertia about it (link frame axes).
#[derive(Debug, Clone, Copy)]
struct Inertial {
    mass: f64,
    com: Vector3<f64>,
    inertia: Matrix3<f64>,
}

impl RobotModel {
    fn inertials(&self) -> Vec<Inertial> {
        self.urdf()
            .links
            .iter()
            .map(|link| {
                let i = &link.inertial;
                let origin = urdf_pose(&i.origin);
                let rotation = origin.rotation.to_rotation_matrix();
                let t = &i.inertia;
                let local = Matrix3::new(
                    t.ixx, t.ixy, t.ixz, //
                    t.ixy, t.iyy, t.iyz, //
                    t.ixz, t.iyz, t.izz,
                );
                Inertial {
                    mass: i.mass.value,
                    com: origin.translation.vector,
                    inertia: rotation.matrix() * local * rotation.matrix().transpose(),
                }
            })
            .collect()
    }

    fn check_state(&self, what: &str, values: &[f64]) -> Result<()> {
        if values.len() != self.num_dofs() {
            return Err(Error::WrongLength {
                what: what.to_string(),
                expected: self.num_dofs(),
                got: values.len(),
            });
        }
        match values.iter().find(|v| !v.is_finite()) {
            None => Ok(()),
            Some(&value) => Err(Error::NonFinite {
                what: what.to_string(),
                value,
            }),
        }
    }

    /// Joint torques (N m; N for the gripper entry, the sum over both fingers) that give
    /// accelerations `qdd` at positions `q` and velocities `qd` under `gravity` (m/s^2,
    /// world frame), with the root link fixed at `base`: `M(q) qdd + C(q, qd) qd + g(q)`.
    pub fn inverse_dynamics(
        &self,
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        gravity: &Vector3<f64>,
        base: &Isometry3<f64>,
    ) -> Result<Vec<f64>> {
        self.check_state("qd", qd)?;
        self.check_state("qdd", qdd)?;
        if !gravity.iter().all(|g| g.is_finite()) {
            return Err(Error::NonFinite {
                what: "gravity".into(),
                value: gravity.norm(),
            });
        }
        let poses = self.link_poses(q, base)?;
        Ok(self.rnea(&poses, &self.inertials(), qd, qdd, gravity))
    }

    /// The torques that hold the robot still at `q` against `gravity`: the inverse dynamics
    /// with zero velocities and accelerations.
    pub fn gravity_torques(
        &self,
        q: &[f64],
        gravity: &Vector3<f64>,
        base: &Isometry3<f64>,
    ) -> Result<Vec<f64>> {
        let zeros = vec![0.0; self.num_dofs()];
        self.inverse_dynamics(q, &zeros, &zeros, gravity, base)
    }

    /// The joint-space mass matrix `M(q)` (`num_dofs x num_dofs`, symmetric positive
    /// definite), column `k` being the inverse dynamics of a unit acceleration of entry `k`.
    pub fn mass_matrix(&self, q: &[f64]) -> Result<DMatrix<f64>> {
        let poses = self.link_poses(q, &Isometry3::identity())?;
        let inertials = self.inertials();
        let n = self.num_dofs();
        let zeros = vec![0.0; n];
        let mut m = DMatrix::zeros(n, n);
        for k in 0..n {
            let mut unit = vec![0.0; n];
            unit[k] = 1.0;
            let column = self.rnea(&poses, &inertials, &zeros, &unit, &Vector3::zeros());
            m.column_mut(k).copy_from_slice(&column);
        }
        // Symmetric by construction up to rounding; make it exactly so.
        Ok((&m + m.transpose()) * 0.5)
    }

    /// The world-frame Jacobian (`6 x num_dofs`: linear velocity rows, then angular) of the
    /// point `point` (in the frame of link `link`) at configuration `q`.
    pub fn jacobian(
        &self,
        link: &str,
        point: &Vector3<f64>,
        q: &[f64],
        base: &Isometry3<f64>,
    ) -> Result<DMatrix<f64>> {
        let target = self.link_index(link)?;
        if !point.iter().all(|v| v.is_finite()) {
            return Err(Error::NonFinite {
                what: "point".into(),
                value: point.norm(),
            });
        }
        let poses = self.link_poses(q, base)?;
        let p = poses[target] * nalgebra::Point3::from(*point);
        let mut jacobian = DMatrix::zeros(6, self.num_dofs());
        let mut link = target;
        while let Some(j) = self.links()[link].parent_joint {
            let joint = &self.joints()[j];
            if let Some((dof, gain)) = self.joint_driver(j) {
                let origin = poses[joint.child_link_index].translation.vector;
                let axis = poses[joint.child_link_index].rotation * joint.axis;
                let (linear, angular) = match joint.joint_type {
                    JointType::Prismatic => (axis, Vector3::zeros()),
                    JointType::Revolute | JointType::Continuous => {
                        (axis.cross(&(p.coords - origin)), axis)
                    }
                    JointType::Fixed => (Vector3::zeros(), Vector3::zeros()),
                };
                for r in 0..3 {
                    jacobian[(r, dof)] += gain * linear[r];
                    jacobian[(r + 3, dof)] += gain * angular[r];
                }
            }
            link = joint.parent_link_index;
        }
        Ok(jacobian)
    }

    /// Recursive Newton-Euler in world coordinates; `qd`, `qdd` per entry of `q`.
    fn rnea(
        &self,
        poses: &[Isometry3<f64>],
        inertials: &[Inertial],
        qd: &[f64],
        qdd: &[f64],
        gravity: &Vector3<f64>,
    ) -> Vec<f64> {
        let links = self.links().len();
        let mut omega = vec![Vector3::zeros(); links];
        let mut alpha = vec![Vector3::zeros(); links];
        // Gravity enters as an upward acceleration of the fixed root.
        let mut acceleration = vec![Vector3::zeros(); links];
        acceleration[self.root_link()] = -gravity;
        let origin = |link: usize| poses[link].translation.vector;
        let mut axes = vec![Vector3::zeros(); self.joints().len()];
        for &j in self.topological_joints() {
            let joint = &self.joints()[j];
            let (parent, child) = (joint.parent_link_index, joint.child_link_index);
            let axis = poses[child].rotation * joint.axis;
            axes[j] = axis;
            let (rate, accel) = self
                .joint_driver(j)
                .map_or((0.0, 0.0), |(dof, gain)| (gain * qd[dof], gain * qdd[dof]));
            let r = origin(child) - origin(parent);
            let (w, a) = (omega[parent], alpha[parent]);
            let mut lin = acceleration[parent] + a.cross(&r) + w.cross(&w.cross(&r));
            match joint.joint_type {
                JointType::Revolute | JointType::Continuous => {
                    omega[child] = w + axis * rate;
                    alpha[child] = a + axis * accel + w.cross(&(axis * rate));
                }
                JointType::Prismatic => {
                    omega[child] = w;
                    alpha[child] = a;
                    lin += axis * accel + 2.0 * w.cross(&(axis * rate));
                }
                JointType::Fixed => {
                    omega[child] = w;
                    alpha[child] = a;
                }
            }
            acceleration[child] = lin;
        }
        // Each link's inertial force and moment (about its frame origin), then summed from the
        // leaves to the root.
        let mut force = vec![Vector3::zeros(); links];
        let mut moment = vec![Vector3::zeros(); links];
        for (link, inertial) in inertials.iter().enumerate() {
            let rotation = poses[link].rotation.to_rotation_matrix();
            let c = rotation * inertial.com;
            let inertia = rotation.matrix() * inertial.inertia * rotation.matrix().transpose();
            let (w, a) = (omega[link], alpha[link]);
            let com_acceleration = acceleration[link] + a.cross(&c) + w.cross(&w.cross(&c));
            let f = inertial.mass * com_acceleration;
            force[link] = f;
            moment[link] = inertia * a + w.cross(&(inertia * w)) + c.cross(&f);
        }
        let mut torques = vec![0.0; self.num_dofs()];
        for &j in self.topological_joints().iter().rev() {
            let joint = &self.joints()[j];
            let (parent, child) = (joint.parent_link_index, joint.child_link_index);
            if let Some((dof, gain)) = self.joint_driver(j) {
                let generalised = match joint.joint_type {
                    JointType::Prismatic => axes[j].dot(&force[child]),
                    _ => axes[j].dot(&moment[child]),
                };
                torques[dof] += gain * generalised;
            }
            let r = origin(child) - origin(parent);
            let (f, n) = (force[child], moment[child]);
            force[parent] += f;
            moment[parent] += n + r.cross(&f);
        }
        torques
    }
}
