//! Forward and inverse kinematics as pure functions of the joint configuration, in f64 on
//! nalgebra. They agree with the physics engine's link poses (see the `physics` tests) but never
//! touch it, so a policy or a user can call them on any `q`.

use nalgebra::{Isometry3, Matrix6, Rotation3, UnitQuaternion, Vector3, Vector6};

use crate::error::{Error, Result};
use crate::model::{JointType, RobotModel};

/// Settings of the damped-least-squares IK solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkOptions {
    /// Maximum number of Gauss-Newton steps.
    pub max_iterations: usize,
    /// Stop when the position error is below this (m).
    pub position_tolerance: f64,
    /// Stop when the orientation error is below this (rad).
    pub orientation_tolerance: f64,
    /// Damping of the least-squares step; larger is more robust near singularities, slower.
    pub damping: f64,
    /// Largest change of any joint in one step (rad or m), so far targets are approached
    /// gradually instead of overshooting.
    pub max_step: f64,
}

impl Default for IkOptions {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            position_tolerance: 1e-6,
            orientation_tolerance: 1e-5,
            damping: 1e-3,
            max_step: 0.2,
        }
    }
}

/// The result of an inverse-kinematics solve.
#[derive(Debug, Clone, PartialEq)]
pub struct IkSolution {
    /// The full configuration (all actuated joints; those outside the chain keep their value).
    pub q: Vec<f64>,
    /// Remaining TCP position error (m).
    pub position_error: f64,
    /// Remaining TCP orientation error (rad); 0 for position-only solves.
    pub orientation_error: f64,
    /// Steps taken.
    pub iterations: usize,
    /// Whether both errors fell below their tolerances.
    pub converged: bool,
}

impl IkSolution {
    /// `Ok(self)` if converged, else [`Error::IkNotConverged`] with the remaining errors.
    pub fn into_result(self) -> Result<Self> {
        if self.converged {
            Ok(self)
        } else {
            Err(Error::IkNotConverged {
                position_error: self.position_error,
                orientation_error: self.orientation_error,
                iterations: self.iterations,
            })
        }
    }
}

/// `orientation` turned so its z axis points straight down, keeping its heading.
pub fn pointing_down(orientation: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    let x = orientation * Vector3::x();
    let heading = Vector3::new(x.x, x.y, 0.0);
    let x = if heading.norm() > 1e-9 {
        heading.normalize()
    } else {
        Vector3::x()
    };
    let z = -Vector3::z();
    let y = z.cross(&x);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_basis_unchecked(&[x, y, z]))
}

impl RobotModel {
    /// World-frame pose of every link (indexed like [`RobotModel::links`]) for configuration `q`,
    /// with the root link at `base`.
    pub fn link_poses(&self, q: &[f64], base: &Isometry3<f64>) -> Result<Vec<Isometry3<f64>>> {
        self.validate_configuration(q)?;
        let mut positions = vec![0.0; self.joints().len()];
        let mut poses = vec![Isometry3::identity(); self.links().len()];
        self.link_poses_into(q, base, &mut positions, &mut poses);
        Ok(poses)
    }

    /// [`RobotModel::link_poses`] into caller-owned buffers (`positions`: one entry per
    /// joint, `poses`: one per link) for a `q` known to be valid: no allocation.
    pub(crate) fn link_poses_into(
        &self,
        q: &[f64],
        base: &Isometry3<f64>,
        positions: &mut [f64],
        poses: &mut [Isometry3<f64>],
    ) {
        self.expand_positions(q, positions);
        poses[self.root_link()] = *base;
        for &j in self.topological_joints() {
            let joint = &self.joints()[j];
            poses[joint.child_link_index] =
                poses[joint.parent_link_index] * self.joint_transform(j, positions[j]);
        }
    }

    /// World-frame pose of the link named `link` for configuration `q`.
    pub fn link_pose(
        &self,
        link: &str,
        q: &[f64],
        base: &Isometry3<f64>,
    ) -> Result<Isometry3<f64>> {
        let index = self.link_index(link)?;
        self.validate_configuration(q)?;
        Ok(self.chain_pose(index, q, base))
    }

    /// World-frame pose of the tool centre point for configuration `q`.
    pub fn tcp_pose(&self, q: &[f64], base: &Isometry3<f64>) -> Result<Isometry3<f64>> {
        self.validate_configuration(q)?;
        Ok(self.chain_pose(self.tcp().link, q, base) * self.tcp().offset)
    }

    /// The joints from the root down to `link`, root first.
    fn chain_to(&self, link: usize) -> Vec<usize> {
        let mut chain = Vec::new();
        let mut current = link;
        while let Some(j) = self.links()[current].parent_joint {
            chain.push(j);
            current = self.joints()[j].parent_link_index;
        }
        chain.reverse();
        chain
    }

    fn chain_pose(&self, link: usize, q: &[f64], base: &Isometry3<f64>) -> Isometry3<f64> {
        self.chain_to(link).into_iter().fold(*base, |pose, j| {
            pose * self.joint_transform(j, self.joint_position(j, q))
        })
    }

    /// Damped-least-squares inverse kinematics for the tool centre point.
    ///
    /// Finds `q` whose TCP reaches `position` and, when given, `orientation` (world frame),
    /// starting from `q_start` (warm start: pass the current configuration). Only joints on the
    /// chain from the root to the TCP link move; every step is clamped into the joint limits.
    /// Returns the best configuration found with its remaining error; check
    /// [`IkSolution::converged`] or call [`IkSolution::into_result`].
    pub fn inverse_kinematics(
        &self,
        position: &Vector3<f64>,
        orientation: Option<&UnitQuaternion<f64>>,
        q_start: &[f64],
        base: &Isometry3<f64>,
        options: &IkOptions,
    ) -> Result<IkSolution> {
        let mut workspace = IkWorkspace::default();
        let report = self.inverse_kinematics_in(
            position,
            orientation,
            q_start,
            base,
            options,
            &mut workspace,
        )?;
        Ok(IkSolution {
            q: workspace.q,
            position_error: report.position_error,
            orientation_error: report.orientation_error,
            iterations: report.iterations,
            converged: report.converged,
        })
    }

    /// [`RobotModel::inverse_kinematics`] without allocating once `workspace` has been used with
    /// this model: the solution is left in [`IkWorkspace::q`].
    pub fn inverse_kinematics_in(
        &self,
        position: &Vector3<f64>,
        orientation: Option<&UnitQuaternion<f64>>,
        q_start: &[f64],
        base: &Isometry3<f64>,
        options: &IkOptions,
        workspace: &mut IkWorkspace,
    ) -> Result<IkReport> {
        self.validate_configuration(q_start)?;
        crate::error::ensure_all_finite("IK target position", position.as_slice())?;
        if let Some(o) = orientation {
            crate::error::ensure_all_finite("IK target orientation", o.coords.as_slice())?;
        }
        workspace.prepare(self);
        let IkWorkspace {
            columns,
            fixed_tail,
            jacobian,
            axes,
            step,
            q,
            ..
        } = workspace;
        let fixed_tail = *fixed_tail;
        q.clear();
        q.extend_from_slice(q_start);
        self.clamp_configuration(q);
        let lambda2 = options.damping * options.damping;
        let mut iterations = 0;
        loop {
            // Forward pass: world axis and origin of each movable chain joint, and the TCP.
            let mut pose = *base;
            for (column, axis) in columns.iter().zip(axes.iter_mut()) {
                pose *= column.before;
                let joint = &self.joints()[column.joint];
                *axis = (pose.rotation * joint.axis, pose.translation.vector);
                pose *= self.joint_motion(column.joint, self.joint_position(column.joint, q));
            }
            let tcp = pose * fixed_tail * self.tcp().offset;
            let p = tcp.translation.vector;
            let position_error = position - p;
            let orientation_error = orientation
                .map(|target| (target * tcp.rotation.inverse()).scaled_axis())
                .unwrap_or_else(Vector3::zeros);
            let (pe, oe) = (position_error.norm(), orientation_error.norm());
            let converged = pe < options.position_tolerance
                && (orientation.is_none() || oe < options.orientation_tolerance);
            let report = IkReport {
                position_error: pe,
                orientation_error: oe,
                iterations,
                converged,
            };
            if converged || iterations >= options.max_iterations {
                return Ok(report);
            }
            iterations += 1;

            // Damped least squares: dq = J^T (J J^T + lambda^2 I)^-1 e. Position-only solves
            // leave the angular rows at zero, so their part of the solution is zero too.
            let mut jjt = Matrix6::identity() * lambda2;
            for ((column, &(axis, origin)), col) in
                columns.iter().zip(axes.iter()).zip(jacobian.iter_mut())
            {
                let (linear, angular) = if column.prismatic {
                    (axis, Vector3::zeros())
                } else {
                    (axis.cross(&(p - origin)), axis)
                };
                // A reused workspace may hold angular rows of an earlier oriented solve.
                let angular = if orientation.is_some() {
                    angular * column.gain
                } else {
                    Vector3::zeros()
                };
                col.fixed_rows_mut::<3>(0)
                    .copy_from(&(linear * column.gain));
                col.fixed_rows_mut::<3>(3).copy_from(&angular);
                jjt += *col * col.transpose();
            }
            let mut error = Vector6::zeros();
            error.fixed_rows_mut::<3>(0).copy_from(&position_error);
            error.fixed_rows_mut::<3>(3).copy_from(&orientation_error);
            let Some(cholesky) = jjt.cholesky() else {
                return Ok(IkReport {
                    converged: false,
                    ..report
                });
            };
            let y = cholesky.solve(&error);
            // Columns of one dof (a joint and its mimics) add up.
            step.clear();
            step.resize(q.len(), 0.0);
            for (column, col) in columns.iter().zip(jacobian.iter()) {
                step[column.dof] += col.dot(&y);
            }
            let largest = step.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let scale = if largest > options.max_step {
                options.max_step / largest
            } else {
                1.0
            };
            for (value, dq) in q.iter_mut().zip(step.iter()) {
                *value += dq * scale;
            }
            self.clamp_configuration(q);
        }
    }
}

/// One movable joint on the chain to the TCP: a column of the Jacobian.
#[derive(Debug, Clone)]
struct Column {
    joint: usize,
    dof: usize,
    gain: f64,
    prismatic: bool,
    /// Fixed transforms between the previous movable joint and this one.
    before: Isometry3<f64>,
}

/// Scratch memory of the IK solver, reusable across solves of one robot model so repeated
/// solves (one per control step) do not allocate.
#[derive(Debug, Clone, Default)]
pub struct IkWorkspace {
    /// The TCP link and joint count the columns were built for.
    built_for: Option<(usize, usize)>,
    columns: Vec<Column>,
    fixed_tail: Isometry3<f64>,
    jacobian: Vec<Vector6<f64>>,
    axes: Vec<(Vector3<f64>, Vector3<f64>)>,
    step: Vec<f64>,
    /// The configuration of the last solve.
    pub q: Vec<f64>,
}

impl IkWorkspace {
    fn prepare(&mut self, model: &RobotModel) {
        let key = (model.tcp().link, model.joints().len());
        if self.built_for == Some(key) {
            return;
        }
        // Each chain joint drives one column: its own dof, or its master's for a mimic joint.
        // Fixed joints fold into the transform in front of the next movable joint.
        self.columns.clear();
        let mut fixed_tail = Isometry3::identity();
        for j in model.chain_to(model.tcp().link) {
            let joint = &model.joints()[j];
            fixed_tail *= joint.origin;
            if let Some((dof, gain)) = model.joint_driver(j) {
                self.columns.push(Column {
                    joint: j,
                    dof,
                    gain,
                    prismatic: joint.joint_type == JointType::Prismatic,
                    before: fixed_tail,
                });
                fixed_tail = Isometry3::identity();
            }
        }
        self.fixed_tail = fixed_tail;
        self.jacobian = vec![Vector6::zeros(); self.columns.len()];
        self.axes = vec![Default::default(); self.columns.len()];
        self.step = Vec::with_capacity(model.num_dofs());
        self.q = Vec::with_capacity(model.num_dofs());
        self.built_for = Some(key);
    }
}

/// The outcome of [`RobotModel::inverse_kinematics_in`] (the configuration is in the workspace).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IkReport {
    /// Remaining TCP position error (m).
    pub position_error: f64,
    /// Remaining TCP orientation error (rad); 0 for position-only solves.
    pub orientation_error: f64,
    /// Steps taken.
    pub iterations: usize,
    /// Whether both errors fell below their tolerances.
    pub converged: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ready() -> Vec<f64> {
        vec![0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785, 0.04]
    }

    #[test]
    fn zero_configuration_matches_the_published_geometry() {
        let model = RobotModel::panda().unwrap();
        let q = vec![0.0, 0.0, 0.0, -0.0698, 0.0, 0.0, 0.0, 0.0];
        let mut q0 = q.clone();
        q0[3] = 0.0;
        // At q = 0 the flange sits at x = 0.088, z = 0.333 + 0.316 + 0.384 - 0.107.
        let poses = {
            let mut positions = vec![0.0; model.joints().len()];
            model.expand_positions(&q0, &mut positions);
            let mut poses = vec![Isometry3::identity(); model.links().len()];
            for &j in model.topological_joints() {
                let joint = &model.joints()[j];
                poses[joint.child_link_index] =
                    poses[joint.parent_link_index] * model.joint_transform(j, positions[j]);
            }
            poses
        };
        let flange = poses[model.link_index("panda_link8").unwrap()]
            .translation
            .vector;
        assert!(
            (flange - Vector3::new(0.088, 0.0, 0.926)).norm() < 1e-9,
            "{flange}"
        );
        let tcp = model.tcp_pose(&q, &Isometry3::identity()).unwrap();
        assert!(tcp.translation.z < 0.926 - 0.1);
    }

    #[test]
    fn ik_reaches_a_pose_it_was_generated_from() {
        let model = RobotModel::panda().unwrap();
        let base = Isometry3::identity();
        let mut target_q = ready();
        target_q[0] = 0.3;
        target_q[1] = -0.4;
        target_q[3] = -2.0;
        let target = model.tcp_pose(&target_q, &base).unwrap();
        let sol = model
            .inverse_kinematics(
                &target.translation.vector,
                Some(&target.rotation),
                &ready(),
                &base,
                &IkOptions::default(),
            )
            .unwrap()
            .into_result()
            .unwrap();
        let reached = model.tcp_pose(&sol.q, &base).unwrap();
        assert!((reached.translation.vector - target.translation.vector).norm() < 1e-6);
        assert!(reached.rotation.angle_to(&target.rotation) < 1e-5);
        assert!(sol.iterations < 30, "{} iterations", sol.iterations);
        for (&j, &v) in model.actuated_joints().iter().zip(&sol.q) {
            let joint = &model.joints()[j];
            assert!(v >= joint.lower && v <= joint.upper, "{} = {v}", joint.name);
        }
        assert_eq!(sol.q[7], 0.04, "the gripper is not on the TCP chain");
    }

    #[test]
    fn unreachable_targets_report_their_error_instead_of_failing_silently() {
        let model = RobotModel::panda().unwrap();
        let sol = model
            .inverse_kinematics(
                &Vector3::new(3.0, 0.0, 0.5),
                None,
                &ready(),
                &Isometry3::identity(),
                &IkOptions::default(),
            )
            .unwrap();
        assert!(!sol.converged);
        assert!(sol.position_error > 2.0);
        assert!(matches!(
            sol.into_result(),
            Err(Error::IkNotConverged { .. })
        ));
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let model = RobotModel::panda().unwrap();
        let base = Isometry3::identity();
        assert!(matches!(
            model.tcp_pose(&[0.0; 3], &base),
            Err(Error::WrongLength {
                expected: 8,
                got: 3,
                ..
            })
        ));
        let mut q = ready();
        q[2] = f64::NAN;
        assert!(matches!(
            model.tcp_pose(&q, &base),
            Err(Error::NonFinite { .. })
        ));
        let err = model
            .inverse_kinematics(
                &Vector3::new(f64::INFINITY, 0.0, 0.0),
                None,
                &ready(),
                &base,
                &IkOptions::default(),
            )
            .unwrap_err();
        assert!(matches!(err, Error::NonFinite { .. }));
    }
}
