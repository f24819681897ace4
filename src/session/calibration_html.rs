//! The HTML report of a medium's RFT shape calibrated from intrusion tests (`terzaghi
//! calibrate --report`): per direction of motion, each test's measured `alpha_x`, `alpha_z`
//! against the fitted shape over the attack angle, and, cross-validated, each test as the shape
//! fitted to the others predicts it. Self-contained, with SVG plots drawn by plotters.

use crate::ident::rft_shape::{HeldOutIntrusion, RftShapeFit, TestSummary};
use anyhow::Result;
use plotters::prelude::*;
use std::f64::consts::FRAC_PI_2;

/// The attack angle (deg) of a test's chord in RFT's frame (the motion toward +x), folded into
/// [-90, 90].
fn attack_deg(t: &TestSummary) -> f64 {
    let a = t.chord_angle_deg.to_radians();
    let m = if t.toward_minus_x { -1.0 } else { 1.0 };
    let mut b = a.sin().atan2(m * a.cos());
    while b > FRAC_PI_2 + 1e-9 {
        b -= std::f64::consts::PI;
    }
    while b < -FRAC_PI_2 - 1e-9 {
        b += std::f64::consts::PI;
    }
    b.to_degrees()
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The report of `fit`, with `held` (cross-validation) where it was run.
pub fn html(fit: &RftShapeFit, held: Option<&[HeldOutIntrusion]>) -> Result<String> {
    let mut s = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>terzaghi calibration: RFT's shape</title>\n<style>body{font-family:sans-serif;max-width:1000px;margin:2em auto;color:#222}table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#eee}td:first-child,th:first-child{text-align:left}</style>\n</head><body>\n<h1>RFT's shape from intrusion tests</h1>\n",
    );
    s += &format!(
        "<p>{} tests, {} rows fitted at {:.3} m/s; form <b>{}</b>{}. Law in depth: the stress at 1 cm ((z + z<sub>0</sub>) / 1 cm)<sup>n</sup>, n {:.3} &plusmn; {:.3}, z<sub>0</sub> {:.1} &plusmn; {:.1} mm. Fitted rows: R<sup>2</sup> fx {:.3}, fz {:.3}.</p>\n",
        fit.tests.len(),
        fit.rows,
        fit.reference_speed_m_s,
        fit.form.name(),
        fit.reduced_because
            .as_deref()
            .map_or(String::new(), |w| format!(" ({})", escape(w))),
        fit.depth_exponent,
        fit.depth_exponent_std,
        fit.surface_offset_m * 1e3,
        fit.surface_offset_std_m * 1e3,
        fit.r2[0],
        fit.r2[1]
    );
    s += "<p>Each panel: one direction of motion (below the horizontal; negative: up), the stress per depth against the plate's attack angle in RFT's frame. Black: each test as measured. Blue: the fitted shape. Red crosses: each test as the shape fitted to the other tests predicts it (with <code>--cross-validate</code>).</p>\n";
    let mut dirs: Vec<f64> = fit
        .tests
        .iter()
        .filter(|t| t.rows_fitted > 0)
        .map(|t| t.direction_deg.round())
        .collect();
    dirs.sort_by(f64::total_cmp);
    dirs.dedup();
    for d in dirs {
        s += &format!("<h2>Moving {:.0} deg below the horizontal</h2>\n", d + 0.0);
        s += &direction_svg(fit, held, d)?;
    }
    s += "</body></html>\n";
    Ok(s)
}

fn direction_svg(fit: &RftShapeFit, held: Option<&[HeldOutIntrusion]>, d: f64) -> Result<String> {
    let mine: Vec<&TestSummary> = fit
        .tests
        .iter()
        .filter(|t| t.rows_fitted > 0 && t.direction_deg.round() == d)
        .collect();
    let predicted: Vec<(f64, [f64; 2])> = held
        .unwrap_or(&[])
        .iter()
        .filter(|h| h.test.direction_deg.round() == d)
        .map(|h| (attack_deg(&h.test), h.predicted_alpha_n_cm3))
        .collect();
    let gamma = d.to_radians();
    let line: Vec<(f64, [f64; 2])> = (-90..=90)
        .map(|b| {
            let (ax, az) = fit.coefficients.alpha(f64::from(b).to_radians(), gamma);
            (f64::from(b), [ax, az])
        })
        .collect();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (950, 360)).into_drawing_area();
        root.fill(&WHITE)?;
        let panels = root.split_evenly((1, 2));
        for (c, area) in panels.iter().enumerate() {
            let name = ["alpha_x (N/cm^3)", "alpha_z (N/cm^3)"][c];
            let values = mine
                .iter()
                .map(|t| t.measured_alpha_n_cm3[c])
                .chain(line.iter().map(|p| p.1[c]))
                .chain(predicted.iter().map(|p| p.1[c]))
                .filter(|v| v.is_finite());
            let (lo, hi) = values.fold((0.0f64, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
            let pad = ((hi - lo) * 0.08).max(1e-4);
            let mut chart = ChartBuilder::on(area)
                .caption(name, ("sans-serif", 16))
                .margin(8)
                .x_label_area_size(30)
                .y_label_area_size(60)
                .build_cartesian_2d(-90.0..90.0, (lo - pad)..(hi + pad))?;
            chart
                .configure_mesh()
                .x_desc("attack angle (deg)")
                .y_desc(name)
                .draw()?;
            chart.draw_series(LineSeries::new(
                line.iter().map(|p| (p.0, p.1[c])),
                BLUE.stroke_width(2),
            ))?;
            chart.draw_series(
                mine.iter()
                    .filter(|t| t.measured_alpha_n_cm3[c].is_finite())
                    .map(|t| {
                        Circle::new(
                            (attack_deg(t), t.measured_alpha_n_cm3[c]),
                            4,
                            BLACK.filled(),
                        )
                    }),
            )?;
            chart.draw_series(
                predicted
                    .iter()
                    .filter(|p| p.1[c].is_finite())
                    .map(|p| Cross::new((p.0, p.1[c]), 5, RED.stroke_width(2))),
            )?;
        }
        root.present()?;
    }
    Ok(svg + "\n")
}
