//! The one error type of the core.

/// Everything that can go wrong in `shieldnav-core`. Every variant names the argument or
/// field at fault, so the Python layer can raise an exception that says what was wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Error {
    /// An argument has a value outside its domain (NaN, inf, a non-positive length, ...).
    #[error("invalid `{name}`: {reason}")]
    InvalidArgument {
        /// The argument's name as the user wrote it.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// Two arguments disagree on a dimension (a planar shield given a 3D `u_nom`, ...).
    #[error("dimension mismatch in `{name}`: expected {expected}, got {got}")]
    DimensionMismatch {
        /// The argument whose dimension is wrong.
        name: &'static str,
        /// The dimension the shield expected.
        expected: usize,
        /// The dimension it was given.
        got: usize,
    },
    /// A numerical solver failed for a reason other than infeasibility.
    #[error("solver failure: {0}")]
    Solver(String),
    /// A scenario preset name that does not exist.
    #[error("unknown preset `{name}`; known presets: {known}")]
    UnknownPreset {
        /// The name asked for.
        name: String,
        /// The known names, comma-separated.
        known: String,
    },
    /// A map, image or scenario file that cannot be read or is malformed.
    #[error("{path}: {location}: {reason}")]
    MapFile {
        /// The file at fault.
        path: String,
        /// Where in it: `line 3`, `field resolution`, `header`, ...
        location: String,
        /// What is wrong.
        reason: String,
    },
}

impl Error {
    /// Shorthand for [`Error::InvalidArgument`].
    pub fn invalid(name: &'static str, reason: impl Into<String>) -> Self {
        Error::InvalidArgument { name, reason: reason.into() }
    }
}

impl Error {
    /// Shorthand for [`Error::MapFile`].
    pub fn map_file(path: impl AsRef<std::path::Path>, location: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::MapFile { path: path.as_ref().display().to_string(), location: location.into(), reason: reason.into() }
    }
}

/// Result alias of the core.
pub type Result<T> = std::result::Result<T, Error>;
