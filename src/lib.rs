//! `terzaghi`: forces on flat and curved legs moving through sand and other granular media, as
//! a ROS 2 node, a library and a command line.
//!
//! The pure core (the models, their identification, the diagnosis's analysis, synthetic
//! sessions) is the crate `terzaghi-core`, re-exported here as [`model`], [`ident`],
//! [`diagnose`] and (with the six-legged robot added) [`sim`]. This crate's modules, lowest
//! first; each uses only the core and those above it in this list:
//!
//! - [`error`]: the failure of a run whose input was fine (an output not written, a DDS
//!   participant not made), which the command line tells from bad input by its exit code.
//! - [`msgs`]: the ROS 2 messages the node reads and writes, and their CDR encoding.
//! - [`medium_file`]: medium files, a plate-sinkage law calibrated from measurements with where
//!   each value came from.
//! - [`mesh_file`]: a body's surface from an STL file (binary or ASCII), for feet and any part
//!   drawn in CAD.
//! - [`model_spec`]: a leg's force model from plain values (kind, plate, medium, fitting width,
//!   RFT coefficients), as the command line and the Python package name it.
//! - [`config`]: node parameters as ROS gives them (params files, `--ros-args`, environment)
//!   validated into a node configuration, and the node's topic names.
//! - [`dataset`]: force logs (CSV) read into samples.
//! - [`record`]: sessions as ROS 2 MCAP files: writing, the recorder thread, reading, recovery.
//! - [`sim`]: the core's synthetic sessions, and the six-legged robot, which speaks the node's
//!   messages (pure).
//! - [`node`]: the node: its core (each message, without DDS or clock), its DDS adapter, its
//!   in-memory transport, the client of a node's parameters.
//! - [`session`]: operations on a session as a user runs them: re-evaluate a recording,
//!   diagnose its legs, identify a leg's medium, record and replay topics; with the writers of
//!   their results.
//! - [`dem`]: runs of the DEM testbed: reading, checking, writing as sessions.
//! - `fuzzing`: what each fuzz target (`fuzz/`) runs on its input, which `cargo test` replays
//!   over the committed corpora and regressions (not an API).
//!
//! The `terzaghi` command line and its demo are the binary's (`src/main.rs`, `src/cli/`,
//! `src/demo.rs`), over all of the above: the library does not reach up to them. The workspace's
//! other binaries (`terzaghi-eval`, `terzaghi-bench`) use the library alone.
//!
//! Cargo features: `node` (default) is the node over DDS, its recorder thread and live view
//! (tokio, ros2-client, RustDDS, Foxglove) and recording and replaying over DDS; `cli`
//! (default) builds the command line's binary. Without them (`default-features = false`) the
//! library is the model, identification, the diagnosis, synthetic sessions and session files.
//!
//! Re-evaluating and diagnosing a recording from Rust, without the command line: see
//! [`session`].
//!
//! The checks of the diagnosis and the models (withheld effects, held-out strokes, the DEM
//! campaign) are the crate `terzaghi-eval`, apart from the product.

#![deny(missing_docs)]

pub mod config;
pub mod dataset;
pub mod dem;
pub mod error;
#[doc(hidden)]
pub mod fuzzing;
pub mod medium_file;
pub mod mesh_file;
pub mod model_spec;
pub mod msgs;
pub mod node;
pub mod record;
pub mod session;
pub mod sim;

pub use terzaghi_core::{diagnose, ident, model};
