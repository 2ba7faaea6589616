//! The operational-space controller (`ee_controller: "osc"`): end-effector actions become joint
//! torques that pull the TCP towards its target pose like a critically damped spring, instead
//! of joint targets from inverse kinematics tracked by the joints' PD motors.
//!
//! With `q`, `qd` the arm's measured joint positions and velocities, `M` its mass matrix, `J`
//! the TCP's world-frame Jacobian (linear rows, then angular), `e = [p_d - p, axis-angle of
//! R_d R^T]` the pose error and `v = J qd` the TCP's twist (robosuite's `OSC_POSE`):
//!
//! ```text
//! Lambda = (J M^-1 J^T)^-1                     task-space inertia (pseudo-inverse near singularities)
//! F      = Lambda (Kp e - Kd v)                Kd = 2 zeta sqrt(Kp), per axis
//! Jbar   = M^-1 J^T Lambda,  N = I - Jbar J    dynamically consistent null space
//! tau    = J^T F + N^T M (kn (q0 - q) - dn qd) + C(q, qd) qd + g(q)      dn = 2 zeta sqrt(kn)
//! ```
//!
//! clamped to the joints' effort limits; `q0` is the robot's start configuration. `Kp` and `kn`
//! are accelerations per unit error (1/s^2), so the gains hold for any arm: 150 (robosuite's
//! default) gives a 12 rad/s natural frequency. The model's rigid-body quantities
//! ([`crate::dynamics`]) are computed from the measured state every physics substep.

use nalgebra::{DMatrix, DVector, Isometry3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::config::{non_negative, positive};
use crate::error::Result;
use crate::model::RobotModel;

/// Gains of the operational-space controller (the `osc` section; used with
/// `ee_controller: "osc"`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OscConfig {
    /// Stiffness of the TCP's position (1/s^2: acceleration per metre of error, scaled by the
    /// task-space inertia). robosuite's `OSC_POSE` default, 150.
    pub position_stiffness: f64,
    /// Stiffness of the TCP's orientation (1/s^2: angular acceleration per radian).
    pub orientation_stiffness: f64,
    /// Damping ratio of every axis (1: critically damped, `Kd = 2 sqrt(Kp)`).
    pub damping_ratio: f64,
    /// Stiffness (1/s^2) of the pull of the null space towards the start configuration
    /// (0: none), damped with the same ratio.
    pub null_space_stiffness: f64,
}

impl Default for OscConfig {
    fn default() -> Self {
        Self {
            position_stiffness: 150.0,
            orientation_stiffness: 150.0,
            damping_ratio: 1.0,
            null_space_stiffness: 10.0,
        }
    }
}

impl OscConfig {
    /// Checks every gain; errors name `osc.<field>`.
    pub fn validate(&self) -> Result<()> {
        positive("osc.position_stiffness", self.position_stiffness)?;
        positive("osc.orientation_stiffness", self.orientation_stiffness)?;
        positive("osc.damping_ratio", self.damping_ratio)?;
        non_negative("osc.null_space_stiffness", self.null_space_stiffness)
    }
}

/// The controller's gains and the robot facts it needs, with scratch buffers.
#[derive(Debug, Clone)]
pub struct Osc {
    config: OscConfig,
    tcp_link: String,
    tcp_point: Vector3<f64>,
    base: Isometry3<f64>,
    gravity: Vector3<f64>,
    arm_dofs: Vec<usize>,
    posture: DVector<f64>,
    effort: DVector<f64>,
    zeros: Vec<f64>,
}

impl Osc {
    /// The controller of the arm `arm_dofs` of `model`, based at `base` under `gravity`,
    /// holding its null space at `start` (one entry per actuated joint).
    pub fn new(
        config: OscConfig,
        model: &RobotModel,
        arm_dofs: &[usize],
        base: Isometry3<f64>,
        gravity: Vector3<f64>,
        start: &[f64],
    ) -> Self {
        let tcp = model.tcp();
        let effort = arm_dofs
            .iter()
            .map(|&dof| model.joints()[model.actuated_joints()[dof]].max_force.abs())
            .collect::<Vec<_>>();
        Self {
            config,
            tcp_link: model.links()[tcp.link].name.clone(),
            tcp_point: tcp.offset.translation.vector,
            base,
            gravity,
            arm_dofs: arm_dofs.to_vec(),
            posture: DVector::from_iterator(arm_dofs.len(), arm_dofs.iter().map(|&d| start[d])),
            effort: DVector::from_vec(effort),
            zeros: vec![0.0; model.num_dofs()],
        }
    }

    /// The entries of `q` the controller drives, in the order of its torques.
    pub fn arm_dofs(&self) -> &[usize] {
        &self.arm_dofs
    }

    /// The arm's joint torques (one per entry of `arm_dofs`, in their order; N m, clamped to
    /// the effort limits) that pull the TCP towards `position`, `orientation` from the state
    /// `q`, `qd` (one entry per actuated joint).
    pub fn torques(
        &self,
        model: &RobotModel,
        q: &[f64],
        qd: &[f64],
        position: &Vector3<f64>,
        orientation: &UnitQuaternion<f64>,
    ) -> Result<DVector<f64>> {
        let n = self.arm_dofs.len();
        let arm = |v: &[f64]| DVector::from_iterator(n, self.arm_dofs.iter().map(|&d| v[d]));
        let full_mass = model.mass_matrix(q)?;
        let mass = DMatrix::from_fn(n, n, |r, c| full_mass[(self.arm_dofs[r], self.arm_dofs[c])]);
        let full_jacobian = model.jacobian(&self.tcp_link, &self.tcp_point, q, &self.base)?;
        let jacobian = DMatrix::from_fn(6, n, |r, c| full_jacobian[(r, self.arm_dofs[c])]);
        let bias = arm(&model.inverse_dynamics(q, qd, &self.zeros, &self.gravity, &self.base)?);
        let tcp = model.tcp_pose(q, &self.base)?;
        let (q, qd) = (arm(q), arm(qd));

        let position_error = position - tcp.translation.vector;
        let orientation_error = (orientation * tcp.rotation.inverse()).scaled_axis();
        let twist = &jacobian * &qd;
        let c = &self.config;
        let kd = |kp: f64| 2.0 * c.damping_ratio * kp.sqrt();
        let mut acceleration = DVector::zeros(6);
        for i in 0..3 {
            acceleration[i] =
                c.position_stiffness * position_error[i] - kd(c.position_stiffness) * twist[i];
            acceleration[i + 3] = c.orientation_stiffness * orientation_error[i]
                - kd(c.orientation_stiffness) * twist[i + 3];
        }
        // The mass matrix is symmetric positive definite; fall back to a pseudo-inverse only
        // if rounding says otherwise.
        let mass_inverse = mass
            .clone()
            .cholesky()
            .map(|ch| ch.inverse())
            .unwrap_or_else(|| {
                mass.clone()
                    .pseudo_inverse(1e-9)
                    .unwrap_or_else(|_| mass.clone())
            });
        let jt = jacobian.transpose();
        let lambda_inverse = &jacobian * &mass_inverse * &jt;
        // Singular values below 1e-4 (directions the arm can hardly move in) are dropped
        // instead of becoming huge task-space inertias.
        let lambda = lambda_inverse
            .clone()
            .pseudo_inverse(1e-4)
            .unwrap_or_else(|_| DMatrix::zeros(6, 6));
        let force = &lambda * acceleration;
        let mut torque = &jt * force;
        if c.null_space_stiffness > 0.0 {
            let jbar = &mass_inverse * &jt * &lambda;
            let null_space = DMatrix::identity(n, n) - jbar * &jacobian;
            let kn = c.null_space_stiffness;
            let posture = &mass * ((&self.posture - &q) * kn - &qd * kd(kn));
            torque += null_space.transpose() * posture;
        }
        torque += bias;
        for (t, &limit) in torque.iter_mut().zip(self.effort.iter()) {
            *t = t.clamp(-limit, limit);
        }
        Ok(torque)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;

    #[test]
    fn bad_gains_are_refused_by_name() {
        type Mutation = fn(&mut OscConfig);
        let cases: [(&str, Mutation); 4] = [
            ("osc.position_stiffness", |c| c.position_stiffness = 0.0),
            ("osc.orientation_stiffness", |c| {
                c.orientation_stiffness = -1.0
            }),
            ("osc.damping_ratio", |c| c.damping_ratio = f64::NAN),
            ("osc.null_space_stiffness", |c| {
                c.null_space_stiffness = -1.0
            }),
        ];
        for (field, mutate) in cases {
            let mut config = OscConfig::default();
            mutate(&mut config);
            match config.validate() {
                Err(Error::InvalidConfig { field: f, .. }) => assert_eq!(f, field),
                other => panic!("{field}: {other:?}"),
            }
        }
        assert!(OscConfig::default().validate().is_ok());
    }
}
