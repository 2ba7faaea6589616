//! `Renderer`: the CPU renderer, drawing a `PandaEnv` or one environment of a
//! `PandaVecEnv` or of a `Evaluation` into an HxWx3 uint8 array; `Cameras`: the image (and
//! touch) observations of one `PandaEnv` (a `PandaVecEnv` runs its own, see `set_cameras`).

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray1, PyArray3};
use panda_rapier_core::{PandaEnv, Sensor, TouchReading, TouchSensor};
use panda_rapier_render::{Cameras, RenderConfig, Renderer};
use pyo3::prelude::*;

use crate::env::NativeEnv;
use crate::errors::{detached, to_py};
use crate::evaluation::NativeEvaluation;
use crate::sensors::{observation_sensor, parse_cameras};
use crate::vector::NativeVecEnv;

/// The default observation camera (`CameraConfig::OBSERVATION`, the camera a policy that sees
/// uses) as JSON: `panda_rapier.pixels.DEFAULT_CAMERA` reads it (its unset fields are `null`).
#[pyfunction]
pub(crate) fn observation_camera_json() -> String {
    serde_json::to_string(&panda_rapier_render::CameraConfig::OBSERVATION).unwrap_or_default()
}

/// Adds the render defaults to the module: `DEFAULT_RENDER_WIDTH` and `DEFAULT_RENDER_HEIGHT`
/// (`RenderConfig::default`'s picture size, which `panda_rapier.rendering` reads) and
/// [`observation_camera_json`].
pub(crate) fn add_defaults(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("DEFAULT_RENDER_WIDTH", RenderConfig::DEFAULT_WIDTH)?;
    m.add("DEFAULT_RENDER_HEIGHT", RenderConfig::DEFAULT_HEIGHT)?;
    m.add("DEPTH_FAR", f64::from(panda_rapier_render::DEPTH_FAR))?;
    m.add_function(wrap_pyfunction!(segmentation_ids, m)?)?;
    m.add_function(wrap_pyfunction!(observation_camera_json, m)?)
}

/// Every segmentation id a camera can see in the environments `config_json` builds, with what
/// it stands for (`background`, `floor`, `platform`, `goal`, `object:<name>`,
/// `link:<name>`), by increasing id (`panda_rapier_render::segmentation`).
#[pyfunction]
pub(crate) fn segmentation_ids(py: Python<'_>, config_json: &str) -> PyResult<Vec<(u8, String)>> {
    // Migration notes were given when the environment was made.
    let (config, _notes) = panda_rapier_core::EnvConfig::from_json_with_notes(config_json)
        .map_err(|e| to_py(py, e))?;
    detached(py, || -> panda_rapier_core::Result<_> {
        let env = PandaEnv::new(config)?;
        Ok(panda_rapier_render::segmentation::table(env.simulation()))
    })?
    .map_err(|e| to_py(py, e))
}

/// A renderer with its own frame buffers (size and camera fixed at construction).
#[pyclass(module = "panda_rapier._native", name = "Renderer")]
pub struct NativeRenderer {
    renderer: Renderer,
}

impl NativeRenderer {
    fn draw<'py>(&mut self, py: Python<'py>, env: &PandaEnv) -> PyResult<Bound<'py, PyArray3<u8>>> {
        let renderer = &mut self.renderer;
        let (h, w) = (
            renderer.config().height as usize,
            renderer.config().width as usize,
        );
        let rgb = detached(py, || renderer.render(env).rgb().to_vec())?;
        let array = Array3::from_shape_vec((h, w, 3), rgb).map_err(|e| {
            to_py(
                py,
                panda_rapier_core::Error::InvalidConfig {
                    field: "render".into(),
                    reason: e.to_string(),
                },
            )
        })?;
        Ok(array.into_pyarray(py))
    }
}

#[pymethods]
impl NativeRenderer {
    #[new]
    fn new(py: Python<'_>, config_json: &str) -> PyResult<Self> {
        let renderer = RenderConfig::from_json(config_json)
            .and_then(Renderer::new)
            .map_err(|e| to_py(py, e))?;
        Ok(Self { renderer })
    }

    /// The full render configuration as JSON (defaults filled in).
    fn config_json(&self) -> String {
        serde_json::to_string(self.renderer.config()).unwrap_or_default()
    }

    #[getter]
    fn width(&self) -> u32 {
        self.renderer.config().width
    }

    #[getter]
    fn height(&self) -> u32 {
        self.renderer.config().height
    }

    /// The environment's current state as an HxWx3 uint8 array.
    fn render_env<'py>(
        &mut self,
        py: Python<'py>,
        env: PyRef<'py, NativeEnv>,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        self.draw(py, &env.env)
    }

    /// Environment `index` of a vector env as an HxWx3 uint8 array.
    fn render_vec_env<'py>(
        &mut self,
        py: Python<'py>,
        envs: PyRef<'py, NativeVecEnv>,
        index: usize,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        let env = envs.vec.env(index).map_err(|e| to_py(py, e))?;
        self.draw(py, env)
    }

    /// Environment `index` of an evaluation's vector env as an HxWx3 uint8 array.
    fn render_evaluation<'py>(
        &mut self,
        py: Python<'py>,
        evaluation: PyRef<'py, NativeEvaluation>,
        index: usize,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        let env = evaluation
            .evaluation
            .envs()
            .env(index)
            .map_err(|e| to_py(py, e))?;
        self.draw(py, env)
    }
}

/// The observation sensors of one environment: the cameras' entries (colour, depth,
/// segmentation, point clouds), then the `touch` entry if asked for, one after the other, as
/// one uint8 array of their bytes (the same bytes a `PandaVecEnv` with `set_cameras` gives its
/// environments).
#[pyclass(module = "panda_rapier._native", name = "Cameras")]
pub struct NativeCameras {
    cameras: Option<Cameras>,
    touch: bool,
    sensor: Option<Box<dyn Sensor>>,
}

/// The `touch` entry's description: key, shape, element type and value bounds.
fn touch_entry() -> (String, Vec<usize>, &'static str, (f64, f64)) {
    (
        TouchSensor::KEY.to_owned(),
        vec![TouchReading::LEN],
        "float32",
        (-TouchReading::BOUND, TouchReading::BOUND),
    )
}

#[pymethods]
impl NativeCameras {
    /// From a JSON list of `{"key": ..., "render": {"width", "height", "camera", "show_goal"},
    /// "modalities": [...], "points": ..., "points_frame": ...}` (the last three optional;
    /// `"[]"` for no camera) and whether the `touch` entry follows.
    #[new]
    #[pyo3(signature = (cameras_json, touch = false))]
    fn new(py: Python<'_>, cameras_json: &str, touch: bool) -> PyResult<Self> {
        let cameras = parse_cameras(py, cameras_json)?;
        let sensor = observation_sensor(cameras.as_ref(), touch);
        Ok(Self {
            cameras,
            touch,
            sensor,
        })
    }

    /// The observation keys of the entries, in order.
    #[getter]
    fn keys(&self) -> Vec<String> {
        let mut keys = self.cameras.as_ref().map_or(Vec::new(), |c| c.keys());
        keys.extend(self.touch.then(|| touch_entry().0));
        keys
    }

    /// Each entry's shape (`(height, width, 3)` for a colour image), in order.
    #[getter]
    fn shapes(&self) -> Vec<Vec<usize>> {
        let mut shapes = self.cameras.as_ref().map_or(Vec::new(), |c| c.shapes());
        shapes.extend(self.touch.then(|| touch_entry().1));
        shapes
    }

    /// Each entry's element type, `"uint8"` or `"float32"` (little-endian), in order.
    #[getter]
    fn dtypes(&self) -> Vec<&'static str> {
        let mut dtypes: Vec<&'static str> = self.cameras.as_ref().map_or(Vec::new(), |c| {
            c.entries().iter().map(|e| e.dtype).collect()
        });
        dtypes.extend(self.touch.then(|| touch_entry().2));
        dtypes
    }

    /// Each entry's `(low, high)` value bounds, in order.
    #[getter]
    fn bounds(&self) -> Vec<(f64, f64)> {
        let mut bounds: Vec<(f64, f64)> = self.cameras.as_ref().map_or(Vec::new(), |c| {
            c.entries().iter().map(|e| e.bounds).collect()
        });
        bounds.extend(self.touch.then(|| touch_entry().3));
        bounds
    }

    /// The entries of the environment's current state, as their bytes (all in order).
    fn observe<'py>(
        &mut self,
        py: Python<'py>,
        env: PyRef<'py, NativeEnv>,
    ) -> PyResult<Bound<'py, PyArray1<u8>>> {
        let env = &env.env;
        let Some(sensor) = self.sensor.as_mut() else {
            return Ok(PyArray1::from_vec(py, Vec::new()));
        };
        let mut out = vec![0; sensor.len()];
        detached(py, || sensor.observe(env, &mut out))?;
        Ok(PyArray1::from_vec(py, out))
    }
}
