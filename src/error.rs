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

/// The exit code of a command that ended with `e`: 1 when the run failed although its input was
/// fine (a [`Failure`]: an output not written, a DDS participant not
/// made, a full disk), 2 for bad input (usage, parameters, geometry, a log or recording that
/// cannot be used, a refusal), 3 when `terzaghi steady` wrote every run but the sand bears
/// some not within the body's height ([`NotBorne`]). 0 is success.
/// `docs/command-line.md` states it.
pub fn exit_code(e: &anyhow::Error) -> u8 {
    // anyhow's downcast finds a Failure given as context at any depth, or as the error itself.
    let failed = e.downcast_ref::<Failure>().is_some()
        || e.chain().any(|c| {
            c.downcast_ref::<std::io::Error>().is_some_and(|io| {
                matches!(
                    io.kind(),
                    std::io::ErrorKind::StorageFull
                        | std::io::ErrorKind::WriteZero
                        | std::io::ErrorKind::QuotaExceeded
                )
            })
        });
    if e.downcast_ref::<NotBorne>().is_some() {
        return 3;
    }
    if failed { 1 } else { 2 }
}
