//! What can be wrong with an inverse-kinematics request.

/// Invalid input to inverse kinematics. Every message says what is valid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IkError {
    /// The target has no points.
    #[error("the target curve has no points; give at least one `x,y,z` row")]
    EmptyTarget,
    /// A CSV row is not three finite numbers.
    #[error("line {line}: {message}")]
    Csv {
        /// 1-based line number in the file.
        line: usize,
        /// What is wrong with it and what is expected.
        message: String,
    },
    /// A point has a NaN or infinite coordinate.
    #[error(
        "target point {index} is not finite: ({x}, {y}, {z}); coordinates must be finite numbers"
    )]
    NonFinite {
        /// 0-based index of the point.
        index: usize,
        /// x coordinate.
        x: f64,
        /// y coordinate.
        y: f64,
        /// z coordinate.
        z: f64,
    },
    /// A point lies beyond [`crate::ik::target::MAX_COORDINATE`].
    #[error(
        "target point {index} ({x}, {y}, {z}) is too far away: coordinates must lie within ±{max} l (units of the fold length l; the boom starts at the origin)",
        max = crate::ik::target::MAX_COORDINATE
    )]
    TooFar {
        /// 0-based index of the point.
        index: usize,
        /// x coordinate.
        x: f64,
        /// y coordinate.
        y: f64,
        /// z coordinate.
        z: f64,
    },
    /// The target is shorter than the shortest module the boom can start with.
    #[error(
        "the target curve is {length} l long, shorter than one module (the shortest state of the bottom module, {module} l): give a curve at least one module long"
    )]
    TooShort {
        /// Arc length of the target (units of l).
        length: f64,
        /// Length of the shortest state of the bottom module (units of l).
        module: f64,
    },
    /// The fit cannot be scored in floating point.
    #[error("the fit's RMS is not a finite number ({0}); the target cannot be fitted")]
    NotFinite(f64),
    /// A generator specification is invalid.
    #[error("{0}")]
    Generator(String),
    /// The boom has no modules.
    #[error("the boom needs at least one module (got m = 0)")]
    NoModules,
    /// A module has no candidate states (e.g. the geometry marks none feasible and `--all-states` is not given).
    #[error("module {module} has no candidate states{hint}")]
    NoCandidates {
        /// 0-based module index (bottom first).
        module: usize,
        /// Extra explanation.
        hint: String,
    },
    /// A module design (n, β) is invalid.
    #[error("invalid module design: {0}")]
    Design(String),
    /// A solver parameter is out of range.
    #[error("{0}")]
    Parameter(String),
}
