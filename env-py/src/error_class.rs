//! Which exception class of `panda_rapier.errors` each core error is raised as. Plain Rust (no
//! pyo3), so the facade's `tests/integration/errors.rs` compiles this file too and checks every variant;
//! this crate has no Rust test harness (see its Cargo.toml).

use panda_rapier_core::Error;

/// The exception classes, each after its bases.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ErrorClass {
    /// `PandaRapierError(Exception)`: the base; also internal errors and failed computations.
    PandaRapier,
    /// `InvalidArgumentError(PandaRapierError, ValueError)`.
    InvalidArgument,
    /// `InvalidActionError(InvalidArgumentError)`.
    InvalidAction,
    /// `ConfigError(InvalidArgumentError)`.
    Config,
    /// `AssetError(PandaRapierError, OSError)`.
    Asset,
    /// `ResetNeededError(PandaRapierError, RuntimeError)`.
    ResetNeeded,
    /// `DisplayError(PandaRapierError, RuntimeError)`: raised by the Python side only.
    Display,
}

impl ErrorClass {
    /// Every class, each after its bases (the order they are created in).
    pub(crate) const ALL: [Self; 7] = [
        Self::PandaRapier,
        Self::InvalidArgument,
        Self::InvalidAction,
        Self::Config,
        Self::Asset,
        Self::ResetNeeded,
        Self::Display,
    ];

    /// The Python name of the class.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Self::PandaRapier => "PandaRapierError",
            Self::InvalidArgument => "InvalidArgumentError",
            Self::InvalidAction => "InvalidActionError",
            Self::Config => "ConfigError",
            Self::Asset => "AssetError",
            Self::ResetNeeded => "ResetNeededError",
            Self::Display => "DisplayError",
        }
    }

    /// The class a core error is raised as: decided by the variant alone.
    pub(crate) fn of(error: &Error) -> Self {
        match error {
            Error::InvalidAction { .. } => Self::InvalidAction,
            Error::InvalidConfig { .. } => Self::Config,
            Error::InvalidOption { .. }
            | Error::NonFinite { .. }
            | Error::WrongLength { .. }
            | Error::UnknownJoint { .. }
            | Error::UnknownLink { .. }
            | Error::JointIndexOutOfRange { .. }
            | Error::JointNotCommandable { .. }
            | Error::SnapshotMismatch { .. } => Self::InvalidArgument,
            Error::AssetNotFound { .. }
            | Error::MalformedUrdf { .. }
            | Error::MissingMesh { .. }
            | Error::BadMesh { .. } => Self::Asset,
            Error::ResetNeeded { .. } => Self::ResetNeeded,
            Error::IkNotConverged { .. } => Self::PandaRapier,
            // `Error` is `#[non_exhaustive]`: a variant added to the core later is raised as the
            // base class until it is given its own arm here.
            _ => Self::PandaRapier,
        }
    }
}
