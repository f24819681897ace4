//! Synthetic sessions: the core's single leg and generator of hidden effects
//! ([`terzaghi_core::sim`]), and the six-legged robot that speaks the node's messages.

pub use terzaghi_core::sim::*;
pub mod robot;
