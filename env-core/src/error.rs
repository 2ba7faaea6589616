//! Typed errors for every fallible entry point of the core.

use std::path::PathBuf;

/// Everything that can go wrong in the simulation core, named for what the caller did wrong or
/// which asset is broken. No public function of this crate panics on bad input.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// A robot description or other asset file does not exist or cannot be read.
    #[error("asset not found or unreadable: {path}: {reason}")]
    AssetNotFound {
        /// The path that was tried.
        path: PathBuf,
        /// What the operating system said.
        reason: String,
    },
    /// The URDF could not be parsed or describes something this simulator cannot build.
    #[error("malformed URDF {source_name}: {reason}")]
    MalformedUrdf {
        /// The file (or `<string>`) the URDF came from.
        source_name: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A mesh referenced by the URDF could not be found.
    #[error("mesh `{filename}` referenced by {urdf} not found (tried: {tried})")]
    MissingMesh {
        /// The filename as written in the URDF.
        filename: String,
        /// The URDF that references it.
        urdf: String,
        /// The candidate paths that were tried, comma separated.
        tried: String,
    },
    /// No joint has this name.
    #[error("unknown joint `{name}` (known joints: {known})")]
    UnknownJoint {
        /// The requested name.
        name: String,
        /// The robot's joint names, comma separated.
        known: String,
    },
    /// No link has this name.
    #[error("unknown link `{name}` (known links: {known})")]
    UnknownLink {
        /// The requested name.
        name: String,
        /// The robot's and scene's link names, comma separated.
        known: String,
    },
    /// A joint index past the end of the joint list.
    #[error("joint index {index} out of range: the robot has {count} joints (0..{count})")]
    JointIndexOutOfRange {
        /// The requested index.
        index: usize,
        /// How many joints there are.
        count: usize,
    },
    /// The joint exists but cannot take this command (fixed joints, mimic joints).
    #[error("joint `{name}` cannot be commanded: {reason}")]
    JointNotCommandable {
        /// The joint's name.
        name: String,
        /// Why not.
        reason: String,
    },
    /// A NaN or infinite number where a finite one is required.
    #[error("{what} must be finite, got {value}")]
    NonFinite {
        /// Which argument.
        what: String,
        /// The offending value.
        value: f64,
    },
    /// A slice of the wrong length.
    #[error("{what} must have {expected} values, got {got}")]
    WrongLength {
        /// Which argument.
        what: String,
        /// The required length.
        expected: usize,
        /// The length passed.
        got: usize,
    },
    /// An action passed to `step` has the wrong number of values or holds a NaN or infinite one.
    /// The environment did not move.
    #[error("{what} {reason}")]
    InvalidAction {
        /// Which action or entry (`action[1]`, `action[1] of environment 2`).
        what: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A reset option has the wrong number of values, holds a NaN or infinite one, or gives a
    /// start state that is not finite.
    #[error("invalid reset option: {what} {reason}")]
    InvalidOption {
        /// Which option or entry (`options.goal[1]`).
        what: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A mesh file that cannot become an object's shape: missing or unreadable, of an unknown
    /// format, malformed, empty, with non-finite coordinates, or with no part of any volume.
    #[error("mesh file {path} (`{field}`) {reason}")]
    BadMesh {
        /// The option or field that names the file (`scene.objects[2].mesh`).
        field: String,
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// A configuration value outside its valid range.
    #[error("invalid config: `{field}` {reason}")]
    InvalidConfig {
        /// The offending field, dotted path (`cube.mass`).
        field: String,
        /// What the valid range is.
        reason: String,
    },
    /// Inverse kinematics did not reach the target within tolerance.
    #[error("inverse kinematics did not converge: position error {position_error:.2e} m, orientation error {orientation_error:.2e} rad after {iterations} iterations")]
    IkNotConverged {
        /// Remaining position error in metres.
        position_error: f64,
        /// Remaining orientation error in radians.
        orientation_error: f64,
        /// Iterations spent.
        iterations: usize,
    },
    /// The call is not valid in the environment's current state (stepping before the first
    /// reset, or after the physics became unstable).
    #[error("reset needed: {reason}")]
    ResetNeeded {
        /// Why a reset is needed first.
        reason: String,
    },
    /// A state snapshot taken from a differently configured world.
    #[error("snapshot does not fit this environment: {reason}")]
    SnapshotMismatch {
        /// What differs.
        reason: String,
    },
}

/// Result alias for the core.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Fails with [`Error::NonFinite`] unless `value` is finite.
pub(crate) fn ensure_finite(what: impl Fn() -> String, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(Error::NonFinite {
            what: what(),
            value,
        })
    }
}

/// Fails with [`Error::WrongLength`] unless `got == expected`.
pub(crate) fn ensure_len(what: &str, expected: usize, got: usize) -> Result<()> {
    if expected == got {
        Ok(())
    } else {
        Err(Error::WrongLength {
            what: what.to_owned(),
            expected,
            got,
        })
    }
}

/// Fails with [`Error::NonFinite`] naming the first non-finite element of `values`.
pub(crate) fn ensure_all_finite(what: &str, values: &[f64]) -> Result<()> {
    for (i, &v) in values.iter().enumerate() {
        ensure_finite(|| format!("{what}[{i}]"), v)?;
    }
    Ok(())
}
