//! What a session operation refuses until its user chooses: replacing a recording, the node's
//! parameters for a log that carries none, the one leg of several. A typed value, so that a
//! program using the library can match on it and the command line can word it in the flag that
//! answers it (`terzaghi::cli::worded`).

use std::path::PathBuf;

/// A refusal that a choice of the user's answers.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// The output exists: a recording is never replaced unless asked to be.
    #[error("{} exists: a recording is not overwritten unless asked to be", path.display())]
    RecordingExists { path: PathBuf },
    /// An MCAP session without the node's parameters: they must be given.
    #[error(
        "{} has no recorded node parameters (it was not recorded by terzaghi node): give the node's parameters",
        file.display()
    )]
    NoRecordedParameters { file: PathBuf },
    /// A CSV log, which carries no node parameters: they must be given.
    #[error(
        "{} is a CSV log, which carries no node parameters: give the node's parameters (a corrected.yaml of terzaghi diagnose, or the robot's parameters)",
        file.display()
    )]
    CsvWithoutParameters { file: PathBuf },
    /// Several legs could be meant: one must be chosen.
    #[error("the session has several legs with F/T topics ({}): choose one", legs.join(", "))]
    SeveralLegs { legs: Vec<String> },
}
