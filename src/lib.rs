//! `terzaghi`: forces on flat legs rotating through sand and other granular media.
//!
//! - [`model`]: the improved and conventional Terzaghi models and RFT (pure).
//! - [`ident`]: identification of the fitting width `b_k, a` (and `delta`) from measured
//!   forces, and goodness of fit (pure).
//! - [`diagnose`]: the analysis of the sim-to-real gap (pure).
//! - [`dataset`]: reading force logs (CSV) into samples (I/O adapter).
//! - [`dem`]: runs of the DEM testbed (reading, checking, writing as sessions) and the models'
//!   fidelity against a campaign (pure).
//! - [`sim`]: synthetic sessions (rotation, forces, sensor noise) for tests and the demo.
//! - [`withheld`]: sessions with a hidden effect from an independent generator, and the check of
//!   the diagnosis on them.
//! - [`cli`]: the `terzaghi` command line.

pub mod cli;
pub mod config;
pub mod dataset;
pub mod dem;
pub mod diagnose;
pub mod ident;
pub mod model;
pub mod msgs;
pub mod node;
pub mod record;
pub mod sim;
pub mod withheld;
