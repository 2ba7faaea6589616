//! The exception classes of `panda_rapier.errors`, created here when `_native` initialises
//! (`panda_rapier/errors.py` re-exports them), core errors as their instances, and a guard that
//! keeps Rust panics from reaching Python as `PanicException` (a `BaseException`).

use std::panic::{catch_unwind, AssertUnwindSafe};

use panda_rapier_core::Error;
use pyo3::exceptions::{PyException, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

pub(crate) use crate::error_class::ErrorClass;

/// The module the classes say they come from: where users import them, and where pickle looks
/// them up.
const MODULE: &str = "panda_rapier.errors";

/// The classes, in [`ErrorClass::ALL`] order.
static CLASSES: PyOnceLock<Vec<Py<PyType>>> = PyOnceLock::new();

impl ErrorClass {
    /// The class's docstring.
    fn doc(self) -> &'static str {
        match self {
            Self::PandaRapier => "Base class of every error raised by panda_rapier.",
            Self::InvalidArgument => {
                "An argument has the wrong shape, dtype or value, or names an unknown joint or link."
            }
            Self::InvalidAction => {
                "An action has the wrong shape or dtype, or holds NaN or infinite values."
            }
            Self::Config => "An environment option is unknown or outside its valid range.",
            Self::Asset => "A robot description or mesh is missing or malformed.",
            Self::ResetNeeded => {
                "The environment must be reset first: before the first reset, after a physics \
                 blow-up,\nafter an episode ended with autoreset disabled, or after ``close()``."
            }
            Self::Display => {
                "``render_mode=\"human\"`` cannot open a window: no display, or pygame is \
                 missing.\n``render_mode=\"rgb_array\"`` needs neither."
            }
        }
    }

    /// The class's bases: ours (already created, in `made`) and a builtin one.
    fn bases<'py>(self, py: Python<'py>, made: &[Py<PyType>]) -> Vec<Bound<'py, PyType>> {
        let ours = |class: Self| made[class as usize].bind(py).clone();
        match self {
            Self::PandaRapier => vec![py.get_type::<PyException>()],
            Self::InvalidArgument => vec![ours(Self::PandaRapier), py.get_type::<PyValueError>()],
            Self::InvalidAction | Self::Config => vec![ours(Self::InvalidArgument)],
            Self::Asset => vec![ours(Self::PandaRapier), py.get_type::<PyOSError>()],
            Self::ResetNeeded | Self::Display => {
                vec![ours(Self::PandaRapier), py.get_type::<PyRuntimeError>()]
            }
        }
    }
}

/// Creates the classes with `type(name, bases, namespace)` (pyo3's `create_exception!` takes a
/// single base; most of ours have two).
fn create(py: Python<'_>) -> PyResult<Vec<Py<PyType>>> {
    let metaclass = py.get_type::<PyType>();
    let mut made: Vec<Py<PyType>> = Vec::with_capacity(ErrorClass::ALL.len());
    for class in ErrorClass::ALL {
        debug_assert_eq!(class as usize, made.len(), "ALL lists the classes in order");
        let bases = PyTuple::new(py, class.bases(py, &made))?;
        let namespace = PyDict::new(py);
        namespace.set_item("__doc__", class.doc())?;
        namespace.set_item("__module__", MODULE)?;
        let created = metaclass
            .call1((class.name(), bases, namespace))?
            .cast_into::<PyType>()?;
        made.push(created.unbind());
    }
    Ok(made)
}

/// The classes (created on first use, normally at module initialisation).
fn classes(py: Python<'_>) -> PyResult<&'static [Py<PyType>]> {
    CLASSES
        .get_or_try_init(py, || create(py))
        .map(Vec::as_slice)
}

/// Adds every class to the native module.
pub(crate) fn add_classes(module: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = module.py();
    for (class, object) in ErrorClass::ALL.iter().zip(classes(py)?) {
        module.add(class.name(), object.bind(py))?;
    }
    Ok(())
}

/// An instance of `class` with `message`.
fn raise(py: Python<'_>, class: ErrorClass, message: String) -> PyErr {
    match classes(py) {
        Ok(classes) => PyErr::from_type(classes[class as usize].bind(py).clone(), message),
        // Unreachable once the module has initialised (it fails if the classes cannot be made).
        Err(error) => error,
    }
}

/// The Python exception for a core error; its class follows from the variant alone
/// ([`ErrorClass::of`]).
pub(crate) fn to_py(py: Python<'_>, error: Error) -> PyErr {
    raise(py, ErrorClass::of(&error), error.to_string())
}

/// An exception of `class` with `message`, for checks made in this crate rather than the core.
pub(crate) fn invalid(py: Python<'_>, class: ErrorClass, message: impl Into<String>) -> PyErr {
    raise(py, class, message.into())
}

/// Runs `f` with the GIL released (other Python threads run meanwhile), turning a panic into
/// `PandaRapierError` instead of pyo3's `PanicException`, which derives from `BaseException` and
/// escapes `except Exception`. No panic is expected: the core reports bad input as errors; this
/// is the last line of defence.
pub(crate) fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    py.detach(|| catch_unwind(AssertUnwindSafe(f)).map_err(panic_message))
        .map_err(|what| {
            raise(
                py,
                ErrorClass::PandaRapier,
                format!(
                    "internal error (please report it): {what}; reset or rebuild the environment"
                ),
            )
        })
}

fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}
