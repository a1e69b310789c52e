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
    /// A generator specification is invalid.
    #[error("{0}")]
    Generator(String),
    /// The boom has no modules.
    #[error("the boom needs at least one module (got m = 0)")]
    NoModules,
    /// A module has no candidate states (e.g. `--feasible-only` and the geometry marks none feasible).
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
