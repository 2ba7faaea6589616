//! `Renderer`: the CPU renderer, drawing a `PandaEnv` or one environment of a
//! `PandaVecEnv` or of a `Evaluation` into an HxWx3 uint8 array.

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3};
use panda_rapier_core::PandaEnv;
use panda_rapier_render::{RenderConfig, Renderer};
use pyo3::prelude::*;

use crate::env::NativeEnv;
use crate::errors::{detached, to_py};
use crate::evaluation::NativeEvaluation;
use crate::vector::NativeVecEnv;

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
