//! `terzaghi`: forces on flat and curved legs moving through sand and other granular media, as
//! a ROS 2 node, a library and a command line.
//!
//! The pure core (the models, their identification, the diagnosis's analysis, synthetic
//! sessions) is the crate `terzaghi-core`, re-exported here as [`model`], [`ident`],
//! [`diagnose`] and (with the six-legged robot added) [`sim`]. This crate's modules, lowest
//! first; each uses only the core and those above it in this list:
//!
//! - [`msgs`]: the ROS 2 messages the node reads and writes, and their CDR encoding.
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
//! - [`demo`]: the six-legged robot walking through the node, for `terzaghi demo`.
//! - [`cli`]: the `terzaghi` command line, over all of the above.
//!
//! Re-evaluating and diagnosing a recording from Rust, without the command line: see
//! [`session`].
//!
//! The checks of the diagnosis and the models (withheld effects, held-out strokes, the DEM
//! campaign) are the crate `terzaghi-eval`, apart from the product.

pub mod cli;
pub mod config;
pub mod dataset;
pub mod dem;
pub mod demo;
pub mod msgs;
pub mod node;
pub mod record;
pub mod session;
pub mod sim;

pub use terzaghi_core::{diagnose, ident, model};
