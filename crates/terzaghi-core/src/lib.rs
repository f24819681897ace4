//! The pure core of `terzaghi`: the force models, their identification from measured forces,
//! the analysis of the gap between model and measurement, and synthetic sessions to check them
//! on. No I/O, clock, DDS or command line: everything here is a function of its inputs.
//!
//! The modules, lowest first; each uses only those above it in this list:
//!
//! - [`model`]: the improved and conventional Terzaghi models, RFT, and the corrected model.
//! - [`ident`]: identification of the fitting width `b_k, a` (and `delta`), of the corrections'
//!   coefficients, of RFT's scale and of the surface's level from measured forces, batch and
//!   online, and goodness of fit.
//! - [`sim`]: synthetic sessions of one leg, and the generator of hidden effects.
//! - [`diagnose`]: the analysis of the sim-to-real gap of one leg's samples.

// Every public item says what it is: this crate is what a user of the models depends on alone.
#![deny(missing_docs)]

pub mod diagnose;
pub mod ident;
pub mod model;
pub mod sim;
