//! What a session operation refuses until its user chooses: replacing a recording, the node's
//! parameters for a log that carries none, the one leg of several. A typed value, so that a
//! program using the library can match on it and the command line can word it in the flag that
//! answers it (the command line's `worded`).

use std::path::PathBuf;

/// A refusal that a choice of the user's answers.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// The output is one of the inputs (the same file by any path): it is never written.
    #[error("the output {} is the input {}: choose another output path", output.display(), input.display())]
    OutputIsInput {
        /// The output.
        output: PathBuf,
        /// The input it is.
        input: PathBuf,
    },
    /// Standard output is one of the inputs (`>> log.csv`): nothing is printed.
    #[error("standard output is the input {}: print elsewhere", input.display())]
    StdoutIsInput {
        /// The input.
        input: PathBuf,
    },
    /// The output exists: a recording is never replaced unless asked to be.
    #[error("{} exists: a recording is not overwritten unless asked to be", path.display())]
    RecordingExists {
        /// The output.
        path: PathBuf,
    },
    /// An MCAP session without the node's parameters: they must be given.
    #[error(
        "{} has no recorded node parameters (it was not recorded by terzaghi node): give the node's parameters",
        file.display()
    )]
    NoRecordedParameters {
        /// The recording.
        file: PathBuf,
    },
    /// A CSV log, which carries no node parameters: they must be given.
    #[error(
        "{} is a CSV log, which carries no node parameters: give the node's parameters (a corrected.yaml of terzaghi diagnose, or the robot's parameters)",
        file.display()
    )]
    CsvWithoutParameters {
        /// The log.
        file: PathBuf,
    },
    /// A CSV log carries no geometry or medium: they must be given.
    #[error("{} is a CSV log: give the leg's geometry and medium", file.display())]
    CsvWithoutGeometry {
        /// The log.
        file: PathBuf,
    },
    /// A leg's geometry given for an MCAP session, whose legs its parameters describe.
    #[error(
        "{} is an MCAP session: its legs are described by the node's parameters (recorded, or given), or a joint's leg with its own geometry",
        file.display()
    )]
    GeometryForSession {
        /// The session.
        file: PathBuf,
    },
    /// A session's leg description (a joint, a parameters file) given for a CSV log.
    #[error(
        "{} is not an MCAP file: a joint or node parameters describe a session's legs; a CSV log takes a geometry and a medium",
        file.display()
    )]
    SessionOptionsForCsv {
        /// The file.
        file: PathBuf,
    },
    /// No leg of the session has an F/T topic to read.
    #[error("no leg has an F/T topic in the parameters (set <leg>.ft_topic)")]
    NoLegWithFt,
    /// Several legs could be meant: one must be chosen.
    #[error("the session has several legs with F/T topics ({}): choose one", legs.join(", "))]
    SeveralLegs {
        /// The legs with F/T.
        legs: Vec<String>,
    },
}
