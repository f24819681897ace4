//! The checks of terzaghi's diagnosis and models, apart from the product: what `terzaghi-eval`
//! runs and the tests read. Nothing here is installed with `terzaghi`.
//!
//! - [`withheld`]: the diagnosis on generated sessions whose hidden effect it is not told.
//! - [`dem_cases`]: the diagnosis on sessions built from a DEM campaign's runs.
//! - [`fidelity`]: the models against a DEM campaign's runs.
//! - [`closed_loop`]: the corrected model a diagnosis wrote, on strokes it did not see, and
//!   learnt online against the batch diagnosis.
//! - [`diagnose_eval`]: the command `terzaghi-eval diagnose-eval`, over the four above.
//! - [`dem_report`]: the command `terzaghi-eval dem-report`.

pub mod closed_loop;
pub mod dem_cases;
pub mod dem_report;
pub mod diagnose_eval;
pub mod fidelity;
pub mod withheld;
