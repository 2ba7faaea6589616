//! Core errors as instances of the Python classes in `panda_rapier.errors`, and a guard that
//! keeps Rust panics from reaching Python as `PanicException` (a `BaseException`).

use std::panic::{catch_unwind, AssertUnwindSafe};

use panda_rapier_core::Error;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

/// Who is to blame for a bad number or length: decides between the `ValueError` subclasses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Blame {
    /// An argument of a method (a configuration, a target, a name).
    Argument,
    /// An action passed to `step`.
    Action,
    /// The environment's configuration.
    Config,
}

/// Instantiates `panda_rapier.errors.<class>(message)`; falls back to a builtin class when the
/// package is not importable (the native module loaded on its own).
fn raise(py: Python<'_>, class: &str, message: String) -> PyErr {
    let made = py
        .import("panda_rapier.errors")
        .and_then(|module| module.getattr(class))
        .and_then(|class| class.call1((message.clone(),)));
    match made {
        Ok(instance) => PyErr::from_value(instance),
        Err(_) if class == "ResetNeededError" || class == "PandaRapierError" => {
            PyRuntimeError::new_err(message)
        }
        Err(_) => PyValueError::new_err(message),
    }
}

/// The Python exception for a core error.
pub(crate) fn to_py(py: Python<'_>, error: Error, blame: Blame) -> PyErr {
    let class = match &error {
        Error::AssetNotFound { .. } | Error::MalformedUrdf { .. } | Error::MissingMesh { .. } => {
            "AssetError"
        }
        Error::InvalidConfig { .. } => match blame {
            Blame::Action => "InvalidActionError",
            Blame::Argument if is_option_error(&error) => "InvalidArgumentError",
            _ => "ConfigError",
        },
        Error::NonFinite { .. } | Error::WrongLength { .. } => match blame {
            Blame::Action => "InvalidActionError",
            Blame::Config => "ConfigError",
            Blame::Argument => "InvalidArgumentError",
        },
        Error::UnknownJoint { .. }
        | Error::UnknownLink { .. }
        | Error::JointIndexOutOfRange { .. }
        | Error::JointNotCommandable { .. }
        | Error::SnapshotMismatch { .. } => "InvalidArgumentError",
        Error::ResetNeeded { .. } => "ResetNeededError",
        _ => "PandaRapierError",
    };
    raise(py, class, error.to_string())
}

/// Reset options are arguments, not configuration, although the core reports a bad start
/// state as an invalid `options` field.
fn is_option_error(error: &Error) -> bool {
    matches!(error, Error::InvalidConfig { field, .. } if field.starts_with("options"))
}

/// An `InvalidArgumentError` (or subclass `class`) with `message`, for checks made here.
pub(crate) fn invalid(py: Python<'_>, class: &str, message: impl Into<String>) -> PyErr {
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
                "PandaRapierError",
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
