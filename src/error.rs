//! The failure of a run whose input was fine, told apart from bad input.

/// What a run could not do although its input was fine: an output that could not be written, a
/// DDS participant or topic that could not be made. The command line exits 1 on it, and 2 on
/// bad input (the command line words both).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct Failure(pub String);

/// Runs of `terzaghi steady` the sand does not bear within the body's height: every run was
/// written, those among them as rows that say so. The command line exits 3 on it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct NotBorne(pub String);
