//! `report.html` of a diagnosis: self-contained, with SVG plots drawn by plotters.

use crate::diagnose::Diagnosis;
use crate::diagnose::report::{Bin, PlotData, Report};
use anyhow::Result;
use plotters::prelude::*;

/// Most measured points drawn per scatter plot.
const MAX_SCATTER: usize = 4000;

pub fn html(leg: &str, d: &Diagnosis) -> Result<String> {
    let r = &d.report;
    let mut s = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>terzaghi diagnosis</title>\n<style>body{font-family:sans-serif;max-width:1000px;margin:2em auto;color:#222}table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}th{background:#eee}td:first-child,th:first-child{text-align:left}.verdict{font-size:1.3em}</style>\n</head><body>\n",
    );
    s += &format!("<h1>Sim-to-real gap: leg {}</h1>\n", escape(leg));
    s += &format!(
        "<p class=\"verdict\">Verdict: <b>{}</b>{}</p>\n",
        escape(r.verdict.effect.name()),
        if r.steps.is_empty() {
            String::new()
        } else {
            format!(
                ", closes {:.0} % of the gap; held-out Psi {:.3} &rarr; {:.3}",
                r.verdict.gap_closed_pct, r.verdict.heldout_psi_before, r.verdict.heldout_psi_after
            )
        }
    );
    s += &format!("<p>What it says: {}.</p>\n", escape(&r.verdict.claim));
    s += &format!("<p>{}</p>\n", escape(&r.summary));
    if !r.corrected_model.terms.is_empty() {
        s += &format!(
            "<p>The corrected model (<code>corrected.yaml</code>) closes {:.0} % of the gap on held-out strokes{}. Its values are fitted on {} samples{}.</p>\n",
            r.corrected_model_gap_closed_pct,
            r.corrected_model_forward_gap_closed_pct
                .map_or(String::new(), |f| format!(
                    ", and {f:.0} % on the session's last third when fitted on the strokes before it (what carries forward to strokes it has not seen)"
                )),
            r.corrected_model_fit_samples,
            r.corrected_model_refit_refused
                .as_ref()
                .map_or(String::new(), |why| format!(
                    ", those the search analysed: their fit on every sample was refused ({})",
                    escape(why)
                ))
        );
    }
    s += &facts_table(r);
    s += "<h2>Measured and predicted forces against attack angle</h2>\n<p>Grey: measured. Blue: baseline model (held-out). Red: with the correction (held-out).</p>\n";
    s += &forces_svg(&d.plot)?;
    s += "<h2>Where the residual lies: attack angle and speed</h2>\n<p>RMS held-out residual of the baseline in each cell, in units of the sensor noise (1 = noise level).</p>\n";
    s += &heatmap_svg(&d.plot)?;
    s += "<h2>Share of the gap by bin</h2>\n<p>Share of the squared residual in excess of the noise; a star marks a bin significantly above the noise (chi-square, z &gt; 4).</p>\n";
    s += &shares_svg(&r.where_)?;
    s += &candidates_table(r);
    s += "</body></html>\n";
    Ok(s)
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn facts_table(r: &Report) -> String {
    format!(
        "<table><tr><th>baseline (held-out)</th><th>value</th></tr>\
<tr><td>b_k, a (fit on every stroke)</td><td>{:.4}, {:.4}</td></tr>\
<tr><td>Psi drag / lift</td><td>{:.4} / {:.4}</td></tr>\
<tr><td>RMSE</td><td>{:.3} N</td></tr>\
<tr><td>sensor noise drag / lift ({})</td><td>{:.3} / {:.3} N</td></tr>\
<tr><td>gap (excess over noise)</td><td>{:.2} x noise variance, z = {:.1}{}</td></tr>\
<tr><td>samples (analysed), strokes, folds</td><td>{} ({}), {}, {}</td></tr></table>\n",
        r.baseline.b_k,
        r.baseline.a,
        r.baseline.psi_drag,
        r.baseline.psi_lift,
        r.baseline.rmse_n,
        r.noise.source.replace('_', " "),
        r.noise.drag_n,
        r.noise.lift_n,
        r.gap.excess_ratio,
        r.gap.z,
        if r.gap.real { "" } else { " (noise level)" },
        r.samples,
        r.analysed,
        r.strokes,
        r.folds
    )
}

fn candidates_table(r: &Report) -> String {
    let mut s = String::from(
        "<h2>Candidate corrections (best first)</h2>\n<table><tr><th>effect</th><th>parameters</th><th>held-out RMSE before (N)</th><th>after (N)</th><th>gap closed</th><th>held-out Psi after</th><th>t over strokes</th><th>direct signature</th></tr>\n",
    );
    for c in &r.candidates {
        s += &format!(
            "<tr><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{}</td><td>{:.4}</td><td>{:.1}</td><td>{}</td></tr>\n",
            c.effect,
            c.parameters,
            c.heldout_rmse_before_n,
            c.heldout_rmse_after_n,
            c.gap_closed_pct
                .map_or("-".to_string(), |g| format!("{g:.0} %")),
            c.heldout_psi_after,
            c.heldout_t,
            if c.direct_evidence { "yes" } else { "" }
        );
    }
    s += "</table>\n";
    if !r.steps.is_empty() {
        s += "<h2>Significant effects, in order</h2>\n<table><tr><th>step</th><th>effect added</th><th>its share of the gap</th><th>gap closed so far</th><th>held-out RMSE (N)</th><th>held-out Psi</th><th>evidence</th><th>what it shows</th></tr>\n";
        for (i, st) in r.steps.iter().enumerate() {
            s += &format!(
                "<tr><td>{}</td><td>{}</td><td>{:.0} %</td><td>{:.0} %</td><td>{:.3}</td><td>{:.4}</td><td>{}</td><td style=\"text-align:left\">{}</td></tr>\n",
                i + 1,
                st.effect,
                st.share_of_gap_pct,
                st.gap_closed_pct,
                st.heldout_rmse_n,
                st.heldout_psi,
                escape(&format!("{}: {}", st.evidence, st.basis)),
                escape(&st.claim)
            );
        }
        s += "</table>\n";
    }
    if let Some(u) = &r.unexplained {
        s += &format!(
            "<h2>What is left</h2>\n<p>{:.0} % of the gap is explained by no significant effect (held-out RMSE {:.3} N once they are modelled).</p>\n",
            u.share_of_gap_pct, u.heldout_rmse_n
        );
        if !u.where_.is_empty() {
            s += "<table><tr><th>where</th><th>bin</th><th>share of what is left</th></tr>\n";
            for b in &u.where_ {
                s += &format!(
                    "<tr><td>{}</td><td>{}</td><td>{:.0} %</td></tr>\n",
                    escape(b.dimension),
                    escape(&b.label),
                    b.share_of_gap
                );
            }
            s += "</table>\n";
        }
        if !u.resembles.is_empty() {
            s += &format!(
                "<p>It resembles (not significant or not material, so not claimed): {}.</p>\n",
                u.resembles
                    .iter()
                    .map(|x| format!(
                        "{} ({:.0} % of what is left)",
                        x.effect, x.share_of_remaining_pct
                    ))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    s
}

/// Mean of `values` in 2-degree bins of attack angle over 0-180 deg: `(deg, mean)`.
fn binned_by_angle(beta: &[f64], values: impl Iterator<Item = f64>) -> Vec<(f64, f64)> {
    let mut sum = [0.0; 90];
    let mut n = [0usize; 90];
    for (b, v) in beta.iter().zip(values) {
        let d = b.to_degrees();
        if (0.0..180.0).contains(&d) {
            let i = (d / 2.0) as usize;
            sum[i] += v;
            n[i] += 1;
        }
    }
    (0..90)
        .filter(|&i| n[i] > 0)
        .map(|i| (2.0 * i as f64 + 1.0, sum[i] / n[i] as f64))
        .collect()
}

fn forces_svg(p: &PlotData) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (950, 420)).into_drawing_area();
        root.fill(&WHITE)?;
        let panels = root.split_evenly((1, 2));
        for (c, area) in panels.iter().enumerate() {
            let name = ["drag (N)", "lift (N)"][c];
            let stride = p.beta_rad.len().div_ceil(MAX_SCATTER).max(1);
            let pts: Vec<(f64, f64)> = p
                .beta_rad
                .iter()
                .zip(&p.measured_n)
                .step_by(stride)
                .map(|(b, y)| (b.to_degrees(), y[c]))
                .filter(|(d, _)| *d < 180.0)
                .collect();
            let before = binned_by_angle(&p.beta_rad, p.before_n.iter().map(|v| v[c]));
            let after = binned_by_angle(&p.beta_rad, p.after_n.iter().map(|v| v[c]));
            let (lo, hi) = pts
                .iter()
                .map(|q| q.1)
                .chain(before.iter().map(|q| q.1))
                .fold((0.0f64, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
            let pad = ((hi - lo) * 0.05).max(1e-6);
            let mut chart = ChartBuilder::on(area)
                .caption(name, ("sans-serif", 16))
                .margin(8)
                .x_label_area_size(30)
                .y_label_area_size(50)
                .build_cartesian_2d(0.0..180.0, (lo - pad)..(hi + pad))?;
            chart
                .configure_mesh()
                .x_desc("attack angle (deg)")
                .y_desc(name)
                .draw()?;
            chart.draw_series(
                pts.iter()
                    .map(|&(x, y)| Circle::new((x, y), 1, RGBColor(150, 150, 150).filled())),
            )?;
            chart.draw_series(LineSeries::new(before, BLUE.stroke_width(2)))?;
            chart.draw_series(LineSeries::new(after, RED.stroke_width(2)))?;
        }
        root.present()?;
    }
    Ok(svg + "\n")
}

fn heatmap_svg(p: &PlotData) -> Result<String> {
    let (na, ns) = (18usize, 8usize);
    let speeds: Vec<f64> = p.speed_rad_s.iter().map(|v| v.abs()).collect();
    let vmax = speeds.iter().copied().fold(0.0f64, f64::max).max(1e-9);
    let mut sum = vec![0.0; na * ns];
    let mut n = vec![0usize; na * ns];
    for (i, (beta, speed)) in p.beta_rad.iter().zip(&speeds).enumerate() {
        let d = beta.to_degrees();
        if !(0.0..180.0).contains(&d) {
            continue;
        }
        let a = ((d / 10.0) as usize).min(na - 1);
        let s = ((speed / vmax * ns as f64) as usize).min(ns - 1);
        let r = (p.measured_n[i][0] - p.before_n[i][0]).powi(2)
            + (p.measured_n[i][1] - p.before_n[i][1]).powi(2);
        sum[a * ns + s] += r / 2.0;
        n[a * ns + s] += 1;
    }
    let sigma2 = p.noise_var_n2.max(1e-18);
    let ratio: Vec<Option<f64>> = (0..na * ns)
        .map(|k| (n[k] > 0).then(|| (sum[k] / n[k] as f64 / sigma2).sqrt()))
        .collect();
    let top = ratio.iter().flatten().copied().fold(1.0f64, f64::max);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (950, 380)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(55)
            .caption(
                format!("RMS residual / noise (white: 1, dark red: {top:.1})"),
                ("sans-serif", 16),
            )
            .build_cartesian_2d(0.0..180.0, 0.0..vmax)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("attack angle (deg)")
            .y_desc("speed (rad/s)")
            .draw()?;
        chart.draw_series((0..na * ns).filter_map(|k| {
            let v = ratio[k]?;
            let (a, s) = (k / ns, k % ns);
            let t = ((v - 1.0) / (top - 1.0).max(1e-9)).clamp(0.0, 1.0);
            let color = RGBColor(
                255 - (90.0 * t) as u8,
                (255.0 * (1.0 - t)) as u8,
                (255.0 * (1.0 - t)) as u8,
            );
            let (x0, y0) = (10.0 * a as f64, vmax * s as f64 / ns as f64);
            Some(Rectangle::new(
                [(x0, y0), (x0 + 10.0, y0 + vmax / ns as f64)],
                color.filled(),
            ))
        }))?;
        root.present()?;
    }
    Ok(svg + "\n")
}

fn shares_svg(bins: &[Bin]) -> Result<String> {
    let shown: Vec<&Bin> = bins.iter().take(16).collect();
    let mut svg = String::new();
    {
        let h = 60 + 24 * shown.len() as u32;
        let root = SVGBackend::with_string(&mut svg, (950, h)).into_drawing_area();
        root.fill(&WHITE)?;
        let max = shown.iter().map(|b| b.share_of_gap).fold(1.0f64, f64::max);
        let min = shown.iter().map(|b| b.share_of_gap).fold(0.0f64, f64::min);
        let rows = shown.len().max(1);
        let mut chart = ChartBuilder::on(&root)
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(10)
            .build_cartesian_2d(min.min(0.0)..max * 1.05, 0.0..rows as f64)?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .disable_y_axis()
            .x_desc("share of the gap (%)")
            .draw()?;
        for (i, b) in shown.iter().enumerate() {
            let y = (rows - 1 - i) as f64;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(0.0, y + 0.15), (b.share_of_gap, y + 0.85)],
                if b.significant {
                    RED.mix(0.6).filled()
                } else {
                    BLUE.mix(0.3).filled()
                },
            )))?;
            chart.draw_series(std::iter::once(Text::new(
                format!(
                    "{}{}: {} ({:.0} %)",
                    if b.significant { "* " } else { "" },
                    b.dimension,
                    b.label,
                    b.share_of_gap
                ),
                (max * 0.01, y + 0.7),
                ("sans-serif", 13),
            )))?;
        }
        root.present()?;
    }
    Ok(svg + "\n")
}
