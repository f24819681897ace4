//! The candidate corrections the diagnosis tries: the terms of the corrected model
//! ([`crate::model::corrections`]), and the grids their nonlinear parameters are searched on.

use super::context::Context;
pub use crate::model::corrections::{ALL, Effect, RATE_EXPONENTS};

/// Name and grid of `effect`'s nonlinear parameter for the session `ctx`, if it has one.
pub fn nonlinear_grid(effect: Effect, ctx: &Context) -> Option<(&'static str, Vec<f64>)> {
    let name = effect.nonlinear_param()?;
    let grid = match effect {
        Effect::Rate => RATE_EXPONENTS.to_vec(),
        // Where in the session the strength changes: at a stroke, or a tenth of the way
        // (sessions of many strokes).
        Effect::Compaction => {
            if ctx.strokes <= 10 {
                (1..ctx.strokes)
                    .map(|k| (k as f64 - 0.5) / (ctx.strokes - 1).max(1) as f64)
                    .collect()
            } else {
                (1..10).map(|k| k as f64 / 10.0).collect()
            }
        }
        Effect::HipHeight => {
            let depth = ctx.model.plate().max_depth_m();
            let grid = [-0.4, -0.25, -0.15, -0.08, 0.08, 0.15, 0.25, 0.4];
            grid.iter().map(|g| g * depth).collect()
        }
        Effect::SensorLag => {
            let mut grid = vec![0.002, 0.005, 0.01, 0.02, 0.035, 0.06, 0.1];
            // A slow sensor's lag is a few of its sample periods (a 12 Hz sensor's are 83 ms):
            // the grid goes on by factors of 1.5 to cover four of them.
            let times: Vec<f64> = ctx.points.iter().map(|p| p.t_s).collect();
            let dt = super::signatures::median_step(&times);
            let mut lag = 0.15;
            while lag <= 4.8 * dt && grid.len() < 16 {
                grid.push(lag);
                lag *= 1.5;
            }
            grid
        }
        _ => return None,
    };
    Some((name, grid))
}
