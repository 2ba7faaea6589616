//! `PandaEnv`: one [`PandaEnv`] and its robot, for `panda_rapier.PandaEnv`.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use panda_rapier_core::{EnvConfig, EnvSnapshot, IkOptions, JointControl, PandaEnv, ResetOptions};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::{
    compute_reward, contiguous, info_dict, pose_tuple, quaternion_xyzw, vector3, ContextColumns,
};
use crate::errors::{detached, invalid, to_py, ErrorClass};

/// Reads a JSON configuration (the Python side serialises the keyword arguments); keys from
/// before 0.2 raise a `FutureWarning` each (shown to users by default), saying what to write.
pub(crate) fn parse_config(py: Python<'_>, config_json: &str) -> PyResult<EnvConfig> {
    let (config, notes) = EnvConfig::from_json_with_notes(config_json).map_err(|e| to_py(py, e))?;
    for note in notes {
        let category = py.get_type::<pyo3::exceptions::PyFutureWarning>();
        let message = std::ffi::CString::new(note.message).unwrap_or_default();
        PyErr::warn(py, &category, &message, 1)?;
    }
    Ok(config)
}

/// A saved environment state (`PandaEnv.snapshot`), restorable into any environment with
/// the same configuration.
#[pyclass(module = "panda_rapier._native", name = "EnvSnapshot", frozen)]
pub struct NativeSnapshot {
    snapshot: EnvSnapshot,
}

/// One pick-and-place environment.
#[pyclass(module = "panda_rapier._native", name = "PandaEnv")]
pub struct NativeEnv {
    pub(crate) env: PandaEnv,
    action: Vec<f32>,
}

impl NativeEnv {
    fn step_result<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyArray1<f32>>, Bound<'py, PyDict>)> {
        Ok((
            PyArray1::from_slice(py, self.env.observation()),
            info_dict(py, self.env.info())?,
        ))
    }

    fn refreshed(&mut self, py: Python<'_>) -> PyResult<()> {
        self.env.refresh().map(|_| ()).map_err(|e| to_py(py, e))
    }
}

#[pymethods]
impl NativeEnv {
    #[new]
    #[pyo3(signature = (config_json, index = 0))]
    fn new(py: Python<'_>, config_json: &str, index: u64) -> PyResult<Self> {
        let config = parse_config(py, config_json)?;
        let env =
            detached(py, || PandaEnv::with_index(config, index))?.map_err(|e| to_py(py, e))?;
        let action = vec![0.0; env.action_dim()];
        Ok(Self { env, action })
    }

    /// The full configuration as JSON (defaults filled in).
    fn config_json(&self) -> String {
        serde_json::to_string(&self.env.config().resolved()).unwrap_or_default()
    }

    #[getter]
    fn action_dim(&self) -> usize {
        self.env.action_dim()
    }

    #[getter]
    fn observation_dim(&self) -> usize {
        self.env.layout().flat_dim()
    }

    /// Control period (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.env.dt()
    }

    /// `(name, start, stop)` of every slot of the flat observation.
    fn observation_slots(&self) -> Vec<(String, usize, usize)> {
        self.env
            .layout()
            .slots()
            .iter()
            .map(|s| (s.name.to_string(), s.range.start, s.range.end))
            .collect()
    }

    /// Starts an episode; returns the flat observation and the info.
    #[pyo3(signature = (seed = None, options_json = None))]
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seed: Option<u64>,
        options_json: Option<&str>,
    ) -> PyResult<(Bound<'py, PyArray1<f32>>, Bound<'py, PyDict>)> {
        let options: ResetOptions = match options_json {
            None => ResetOptions::default(),
            // Through a `Value`, so an unknown or mistyped option's message names the option
            // and what is expected, without a JSON line and column.
            Some(text) => serde_json::from_str::<serde_json::Value>(text)
                .and_then(serde_json::from_value)
                .map_err(|e| {
                    invalid(
                        py,
                        ErrorClass::InvalidArgument,
                        format!("reset options: {e}"),
                    )
                })?,
        };
        let env = &mut self.env;
        detached(py, || env.reset(seed, &options).map(|_| ()))?.map_err(|e| to_py(py, e))?;
        self.step_result(py)
    }

    /// One control step with a float32 action of length `action_dim`.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        action: PyReadonlyArray1<'py, f32>,
    ) -> PyResult<(
        Bound<'py, PyArray1<f32>>,
        f64,
        bool,
        bool,
        Bound<'py, PyDict>,
    )> {
        let values = contiguous(py, &action, "action")?;
        if values.len() != self.action.len() {
            return Err(invalid(
                py,
                ErrorClass::InvalidAction,
                format!(
                    "action must have shape ({},), got ({},)",
                    self.action.len(),
                    values.len()
                ),
            ));
        }
        self.action.copy_from_slice(values);
        let Self { env, action } = self;
        let transition = detached(py, || env.step(action))?.map_err(|e| to_py(py, e))?;
        let (observation, info) = self.step_result(py)?;
        Ok((
            observation,
            f64::from(transition.reward),
            transition.terminated,
            transition.truncated,
            info,
        ))
    }

    /// Whether `step` would refuse until the next reset.
    fn needs_reset(&self) -> bool {
        self.env.needs_reset()
    }

    /// The current flat observation and info.
    fn current<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyArray1<f32>>, Bound<'py, PyDict>)> {
        self.step_result(py)
    }

    /// The goal (for pick-and-place the cube centre's goal position).
    fn goal(&self) -> Vec<f64> {
        self.env.goal().to_vec()
    }

    /// Batched reward (see `panda_rapier.PandaEnv.compute_reward`).
    #[pyo3(signature = (achieved_goal, desired_goal, context = None))]
    fn compute_reward<'py>(
        &self,
        py: Python<'py>,
        achieved_goal: PyReadonlyArray2<'py, f32>,
        desired_goal: PyReadonlyArray2<'py, f32>,
        context: Option<ContextColumns<'py>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        compute_reward(
            py,
            self.env.layout().goal_dim(),
            |a, d, c, out| self.env.compute_rewards(a, d, c, out),
            achieved_goal,
            desired_goal,
            context,
        )
    }

    /// Copies the whole state (physics, random stream, goal, clock).
    fn snapshot(&self) -> NativeSnapshot {
        NativeSnapshot {
            snapshot: self.env.snapshot(),
        }
    }

    /// Returns to a saved state; stepping on continues bit-identically.
    fn restore(&mut self, py: Python<'_>, snapshot: &NativeSnapshot) -> PyResult<()> {
        self.env
            .restore(&snapshot.snapshot)
            .map_err(|e| to_py(py, e))
    }

    // ---- the robot ------------------------------------------------------------------------

    /// Every joint of the robot (fixed ones included), as dicts.
    fn joint_info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        let config = self.env.simulation().config();
        for joint in self.env.simulation().model().joints() {
            let dict = PyDict::new(py);
            // What the simulation applies: the configuration's override, else the URDF's.
            let movable = joint.joint_type.is_movable();
            let passive =
                |set: Option<f64>, urdf: f64| if movable { set.unwrap_or(urdf) } else { 0.0 };
            dict.set_item(
                "damping",
                passive(config.robot.joint_damping, joint.damping),
            )?;
            dict.set_item(
                "friction",
                passive(config.robot.joint_friction, joint.friction),
            )?;
            dict.set_item("index", joint.index)?;
            dict.set_item("name", &joint.name)?;
            dict.set_item("type", joint.joint_type.as_str())?;
            dict.set_item("lower", joint.lower)?;
            dict.set_item("upper", joint.upper)?;
            dict.set_item("max_force", joint.max_force)?;
            dict.set_item("max_velocity", joint.max_velocity)?;
            dict.set_item("axis", <[f64; 3]>::from(joint.axis))?;
            dict.set_item("parent_link", &joint.parent_link)?;
            dict.set_item("child_link", &joint.child_link)?;
            dict.set_item("dof", joint.dof)?;
            dict.set_item("mimic", joint.mimic.map(|m| m.master))?;
            list.append(dict)?;
        }
        Ok(list)
    }

    /// Link names in URDF order.
    fn link_names(&self) -> Vec<String> {
        let model = self.env.simulation().model();
        model.links().iter().map(|l| l.name.clone()).collect()
    }

    /// Pose, velocity and physical properties of a link.
    fn link_state<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
        let link = self
            .env
            .simulation()
            .link_state(name)
            .map_err(|e| to_py(py, e))?;
        let dict = PyDict::new(py);
        let s = link.state;
        let q = s.orientation.coords;
        dict.set_item("index", link.index)?;
        dict.set_item("name", link.name)?;
        dict.set_item("mass", link.mass)?;
        dict.set_item("friction", link.friction)?;
        dict.set_item("num_colliders", link.num_colliders)?;
        dict.set_item("position", <[f64; 3]>::from(s.position))?;
        dict.set_item("orientation", [q.x, q.y, q.z, q.w])?;
        dict.set_item("linear_velocity", <[f64; 3]>::from(s.linear_velocity))?;
        dict.set_item("angular_velocity", <[f64; 3]>::from(s.angular_velocity))?;
        Ok(dict)
    }

    /// Positions and velocities of the actuated joints (the configuration `q`).
    fn joint_states(&self) -> (Vec<f64>, Vec<f64>) {
        let sim = self.env.simulation();
        (sim.joint_positions(), sim.joint_velocities())
    }

    /// Number of entries of `q`.
    #[getter]
    fn num_dofs(&self) -> usize {
        self.env.simulation().model().num_dofs()
    }

    /// Teleports the robot to `q` at rest (position control holds it) and refreshes the
    /// observation.
    fn set_joint_positions(&mut self, py: Python<'_>, q: Vec<f64>) -> PyResult<()> {
        self.env
            .simulation_mut()
            .set_joint_positions(&q)
            .map_err(|e| to_py(py, e))?;
        self.refreshed(py)
    }

    /// Sets how joint `joint` (index or name) is driven: `mode` is `position`, `velocity` or
    /// `torque`.
    #[pyo3(signature = (joint, mode, target, target_velocity = 0.0, max_force = None))]
    fn set_joint_control(
        &mut self,
        py: Python<'_>,
        joint: &Bound<'_, PyAny>,
        mode: &str,
        target: f64,
        target_velocity: f64,
        max_force: Option<f64>,
    ) -> PyResult<()> {
        let control = match mode {
            "position" => JointControl::Position {
                target,
                target_velocity,
                max_force,
            },
            "velocity" => JointControl::Velocity { target, max_force },
            "torque" => JointControl::Torque(target),
            other => {
                return Err(invalid(
                    py,
                    ErrorClass::InvalidArgument,
                    format!(
                        "control mode must be 'position', 'velocity' or 'torque', got {other:?}"
                    ),
                ))
            }
        };
        let sim = self.env.simulation_mut();
        let result = if let Ok(name) = joint.extract::<String>() {
            sim.set_joint_control_by_name(&name, control)
        } else if let Ok(index) = joint.extract::<usize>() {
            sim.set_joint_control(index, control)
        } else {
            return Err(invalid(
                py,
                ErrorClass::InvalidArgument,
                "joint must be a joint index (int >= 0) or name (str)",
            ));
        };
        result.map_err(|e| to_py(py, e))
    }

    /// Advances the physics by `steps` solver steps with the current joint controls, then
    /// refreshes the observation (the episode clock does not move); the touch reading is the
    /// mean over these steps.
    #[pyo3(signature = (steps = 1))]
    fn step_simulation(&mut self, py: Python<'_>, steps: u32) -> PyResult<()> {
        let sim = self.env.simulation_mut();
        sim.begin_touch_window();
        detached(py, || (0..steps).for_each(|_| sim.step()))?;
        self.refreshed(py)
    }

    /// World poses `(position, quaternion xyzw)` of every link, and of `tcp`, for configuration
    /// `q` (pure kinematics; the simulation is not touched).
    fn forward_kinematics<'py>(
        &self,
        py: Python<'py>,
        q: Vec<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let sim = self.env.simulation();
        let model = sim.model();
        let err = |e| to_py(py, e);
        let poses = model.link_poses(&q, sim.base_pose()).map_err(err)?;
        let dict = PyDict::new(py);
        for (link, pose) in model.links().iter().zip(&poses) {
            dict.set_item(&link.name, pose_tuple(pose))?;
        }
        let tcp = model.tcp_pose(&q, sim.base_pose()).map_err(err)?;
        dict.set_item("tcp", pose_tuple(&tcp))?;
        Ok(dict)
    }

    /// Joint torques `M(q) qdd + C(q, qd) qd + g(q)` of the robot model under the
    /// simulation's gravity (`panda_rapier_core::dynamics`).
    fn inverse_dynamics(
        &self,
        py: Python<'_>,
        q: Vec<f64>,
        qd: Vec<f64>,
        qdd: Vec<f64>,
    ) -> PyResult<Vec<f64>> {
        let sim = self.env.simulation();
        let [x, y, z] = sim.config().physics.gravity;
        let gravity = panda_rapier_core::nalgebra::Vector3::new(x, y, z);
        sim.model()
            .inverse_dynamics(&q, &qd, &qdd, &gravity, sim.base_pose())
            .map_err(|e| to_py(py, e))
    }

    /// The joint-space mass matrix at `q` (`num_dofs x num_dofs`).
    fn mass_matrix<'py>(
        &self,
        py: Python<'py>,
        q: Vec<f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let m = self
            .env
            .simulation()
            .model()
            .mass_matrix(&q)
            .map_err(|e| to_py(py, e))?;
        row_major(py, &m)
    }

    /// The world-frame Jacobian (`6 x num_dofs`, linear rows first) of `point` in link `link`'s
    /// frame (`tcp`: the tool centre point, `point` in its frame) at `q`.
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        link: &str,
        point: [f64; 3],
        q: Vec<f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let sim = self.env.simulation();
        let model = sim.model();
        let (name, point) = if link == "tcp" {
            let tcp = model.tcp();
            let p = tcp.offset * panda_rapier_core::nalgebra::Point3::from(vector3(point));
            (model.links()[tcp.link].name.clone(), p.coords)
        } else {
            (link.to_string(), vector3(point))
        };
        let j = model
            .jacobian(&name, &point, &q, sim.base_pose())
            .map_err(|e| to_py(py, e))?;
        row_major(py, &j)
    }

    /// Damped-least-squares IK for the TCP; see `panda_rapier.Robot.inverse_kinematics`.
    #[pyo3(signature = (position, orientation = None, q_start = None, max_iterations = 100))]
    fn inverse_kinematics<'py>(
        &self,
        py: Python<'py>,
        position: [f64; 3],
        orientation: Option<[f64; 4]>,
        q_start: Option<Vec<f64>>,
        max_iterations: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        let sim = self.env.simulation();
        let orientation = orientation.map(|q| quaternion_xyzw(py, q)).transpose()?;
        let start = q_start.unwrap_or_else(|| sim.joint_positions());
        let options = IkOptions {
            max_iterations,
            ..IkOptions::default()
        };
        let solution = sim
            .model()
            .inverse_kinematics(
                &vector3(position),
                orientation.as_ref(),
                &start,
                sim.base_pose(),
                &options,
            )
            .map_err(|e| to_py(py, e))?;
        let dict = PyDict::new(py);
        dict.set_item("q", solution.q)?;
        dict.set_item("position_error", solution.position_error)?;
        dict.set_item("orientation_error", solution.orientation_error)?;
        dict.set_item("iterations", solution.iterations)?;
        dict.set_item("converged", solution.converged)?;
        Ok(dict)
    }

    /// Pose and velocity of the object called `name`.
    #[pyo3(signature = (name = "cube"))]
    fn object_state<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
        let sim = self.env.simulation();
        let cube = sim.object(name).map_err(|e| crate::errors::to_py(py, e))?;
        let s = sim.object_state(cube);
        let q = s.orientation.coords;
        let dict = PyDict::new(py);
        dict.set_item("position", <[f64; 3]>::from(s.position))?;
        dict.set_item("orientation", [q.x, q.y, q.z, q.w])?;
        dict.set_item("linear_velocity", <[f64; 3]>::from(s.linear_velocity))?;
        dict.set_item("angular_velocity", <[f64; 3]>::from(s.angular_velocity))?;
        Ok(dict)
    }

    /// What the hand felt over the last control step (`Simulation::touch`: means over its
    /// physics steps):
    /// `finger_normal_forces` (2, N), `finger_forces` (2 x 3, N, world frame),
    /// `wrist_force` (N) and `wrist_torque` (N m, about the hand origin), both in the hand
    /// frame, the wrench the hand subtree exerts on the arm; and `hand_mass` (kg), the
    /// subtree's mass.
    fn touch<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let sim = self.env.simulation();
        let touch = sim.touch();
        let [a, b] = touch.fingers;
        let dict = PyDict::new(py);
        dict.set_item("finger_normal_forces", [a.normal_force, b.normal_force])?;
        dict.set_item(
            "finger_forces",
            [<[f64; 3]>::from(a.force), <[f64; 3]>::from(b.force)],
        )?;
        dict.set_item("wrist_force", <[f64; 3]>::from(touch.wrist.force))?;
        dict.set_item("wrist_torque", <[f64; 3]>::from(touch.wrist.torque))?;
        dict.set_item("hand_mass", sim.hand_subtree_mass())?;
        Ok(dict)
    }
}

/// A matrix as a numpy array (nalgebra stores columns first, numpy rows: the transpose's
/// storage is the matrix's rows).
fn row_major<'py>(
    py: Python<'py>,
    m: &panda_rapier_core::nalgebra::DMatrix<f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    PyArray1::from_slice(py, m.transpose().as_slice()).reshape([m.nrows(), m.ncols()])
}
