//! Diagnosis of the sim-to-real gap (pure analysis: samples in, a report value out).
//!
//! - [`kinematics`]: strokes from the angle, angular speed and acceleration by smoothed
//!   differentiation.
//! - [`baseline`]: `b_k, a` fitted on training strokes and scored on held-out strokes, by folds
//!   of whole strokes, so that nothing is scored on what was fitted.

pub mod baseline;
pub mod kinematics;

pub use baseline::{Baseline, BaselineOptions, cross_validated_baseline};
pub use kinematics::{Kinematics, kinematics};
