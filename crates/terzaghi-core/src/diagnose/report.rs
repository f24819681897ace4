//! The analysis behind a diagnosis, and its report (serialized as `report.json`).

use super::DiagnoseOptions;
use super::context::{Context, Point, lowest_of_twofold_span, median};
use super::effects::{ALL, Effect};
use super::fit::{Design, Fit, fit};
use super::signatures::{self, Signatures, t_critical_5pct, t_statistic};
use crate::model::Regime;
use crate::model::corrections::{Corrections, CorrectionsError, Term};
use std::collections::BTreeMap;

/// The report and the per-point series behind its plots.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// The report, as `report.json` writes it.
    pub report: Report,
    /// The series behind the report's plots.
    pub plot: PlotData,
}

/// Standard deviations of a corrected model's values: the delete-a-fold jackknife over the
/// fit's folds of whole strokes, each fitted on every stroke but its own (nonlinear values, such
/// as a sensor's lag, held as each fold chose them).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CorrectedStd {
    /// Of `b_k`.
    pub b_k: f64,
    /// Of `a`.
    pub a: f64,
    /// Of each term's coefficients, in the order of the corrected model's terms.
    pub terms: Vec<Term>,
}

/// The standard deviations of the corrected model `f` gives ([`corrected_model`]).
pub(crate) fn corrected_std(f: &Fit) -> Option<CorrectedStd> {
    let s = f.std.as_ref()?;
    let mut terms = Vec::with_capacity(f.design.effects.len());
    let mut j = 1;
    for &e in &f.design.effects {
        let n = e.linear_params().len();
        terms.push(Term {
            effect: e,
            coefficients: s.coefficients[j..j + n].to_vec(),
        });
        j += n;
    }
    Some(CorrectedStd {
        b_k: s.coefficients[0],
        a: s.a,
        terms,
    })
}

/// What the diagnosis found in a leg's session: the gap between model and measurement, where it
/// lies, the candidate effects, the steps taken and the verdict.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Report {
    /// Samples given.
    pub samples: usize,
    /// Samples analysed, after thinning to the analysis's maximum.
    pub analysed: usize,
    /// Samples skipped for a non-finite time, angle or force.
    pub skipped_non_finite: usize,
    /// Strokes (full turns) in the session.
    pub strokes: usize,
    /// Folds of strokes the held-out fits are made over.
    pub folds: usize,
    /// The sensor's noise, against which the gap is measured.
    pub noise: Noise,
    /// The improved model fitted alone, and its held-out fit.
    pub baseline: Baseline,
    /// The gap: the baseline's held-out residual against the noise.
    pub gap: Gap,
    /// Where the baseline's residual lies: bins of attack angle, depth, speed and stroke.
    #[serde(rename = "where")]
    pub where_: Vec<Bin>,
    /// Every candidate effect fitted alone on top of the baseline.
    pub candidates: Vec<Candidate>,
    /// The effects taken, one at a time, each on top of those before it.
    pub steps: Vec<Step>,
    /// What the report names, with its share of the gap and its basis.
    pub verdict: Verdict,
    /// The report in a few sentences, for a person.
    pub summary: String,
    /// The part of the gap no significant effect explains (null when the gap is at the noise
    /// level): the model's own misfit, where it lies, and which candidates it resembles.
    pub unexplained: Option<Unexplained>,
    /// Direct signatures of a sensor offset, a delay and a surface level.
    pub signatures: Signatures,
    /// The corrected model of every step taken, fitted on every stroke: what the node predicts
    /// with once given it (`corrected.yaml`). The baseline's `b_k, a` alone without steps.
    pub corrected_model: Corrections,
    /// Standard deviations of the corrected model's `b_k`, `a` and terms' coefficients, from
    /// the folds of the fit that gave them (see [`CorrectedStd`]); `None` with fewer than two
    /// folds.
    pub corrected_model_std: Option<CorrectedStd>,
    /// Share of the gap the corrected model closes on held-out strokes, %: the last step's
    /// `gap_closed_pct` it holds (0 with no step).
    pub corrected_model_gap_closed_pct: f64,
    /// Share of the gap the corrected model closes on the session's last third of strokes,
    /// fitted on the strokes before them (its terms and nonlinear values as the whole session
    /// chose them), %: what carries forward to strokes it has not seen. Below
    /// `corrected_model_gap_closed_pct` where the session drifts (a bed a leg digs its trough in,
    /// speeds that rise) and a term takes up misfit of the earlier strokes only. `None` with
    /// fewer than three strokes, without a step, without a gap on the last third, or without
    /// [`DiagnoseOptions::forward_share`](super::DiagnoseOptions::forward_share).
    pub corrected_model_forward_gap_closed_pct: Option<f64>,
    /// Steps whose fit left the terms' physical bounds, with the value that did: the corrected
    /// model stops before the first of them, unless a later step's fit is within bounds again.
    pub corrected_model_left_out: Vec<String>,
    /// Samples the corrected model's values were fitted on: every usable sample up to
    /// `max_fit_points`, or the search's `analysed` where the search saw every one, kept no
    /// term, or the fit on every sample left the terms' bounds (then the search's values stand,
    /// and `corrected_model_refit_refused` says why).
    pub corrected_model_fit_samples: usize,
    /// Why the corrected model's fit on every sample was refused (a value out of its bounds),
    /// and the search's values written instead; `None` where it was taken or not needed.
    pub corrected_model_refit_refused: Option<String>,
    /// Analysed points whose hip the robot's state placed (a recording's `/tf` or body pose,
    /// for a leg with a `hip_frame`): modelled at that hip's height and attack angle, the
    /// others at the configured height. 0 for a leg at a fixed height.
    pub hip_placed_points: usize,
}

/// The part of the gap no significant effect explains.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Unexplained {
    /// Share of the gap left once every significant effect is modelled, %.
    pub share_of_gap_pct: f64,
    /// Held-out RMSE with every significant effect modelled, over drag and lift (N).
    pub heldout_rmse_n: f64,
    /// Where the remaining residual lies: in each of attack angle, depth, speed and stroke, its
    /// two largest significant bins, largest share first (shares of the remaining gap).
    #[serde(rename = "where")]
    pub where_: Vec<Bin>,
    /// Effects whose terms would close part of what remains, without being significant or
    /// material: what the remaining misfit resembles, not a claim.
    pub resembles: Vec<Resemblance>,
}

/// An effect whose term would close part of what remains.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Resemblance {
    /// The effect.
    pub effect: Effect,
    /// Share of the remaining gap its term closes on held-out strokes, %.
    pub share_of_remaining_pct: f64,
}

/// The sensor's noise, per component.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Noise {
    /// Drag's noise standard deviation (N).
    pub drag_n: f64,
    /// Lift's noise standard deviation (N).
    pub lift_n: f64,
    /// `out_of_medium` (measured where the leg is out of the medium) or `successive_differences`
    /// (too few such samples: from sample-to-sample differences).
    pub source: &'static str,
    /// Samples the noise was measured on.
    pub samples: usize,
    /// The sensor's quantisation step (N): the smallest step between the distinct values it
    /// reported, over drag and lift (as small as the log's digits where it is not quantised).
    pub quantum_n: f64,
}

/// The improved model alone, fitted on every stroke.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Baseline {
    /// The fitting width's coefficient `b_k`.
    pub b_k: f64,
    /// The fitting width's exponent base `a`.
    pub a: f64,
    /// Held-out goodness of fit of drag (Eq. 28).
    pub psi_drag: f64,
    /// Held-out goodness of fit of lift (Eq. 28).
    pub psi_lift: f64,
    /// Held-out RMSE over drag and lift (N).
    pub rmse_n: f64,
}

/// The baseline's held-out residual against the noise.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Gap {
    /// Whether the held-out residual exceeds the noise beyond chance and by the set ratio.
    pub real: bool,
    /// Held-out mean squared residual over drag and lift (N^2).
    pub heldout_mse_n2: f64,
    /// The noise's variance over drag and lift (N^2).
    pub noise_var_n2: f64,
    /// `(mse - noise) / noise`.
    pub excess_ratio: f64,
    /// Chi-square test of the residual against the noise, as a z score.
    pub z: f64,
    /// The gap: the held-out RMS residual in excess of the noise (N).
    pub gap_rms_n: f64,
    /// The smallest gap the sensor resolves (N): the larger of the stated floor
    /// ([`super::DiagnoseOptions::min_gap_n`]) and the sensor's quantisation step.
    pub resolution_n: f64,
    /// The gap is smaller than the sensor resolves: nothing to explain, however well an effect
    /// would fit it.
    pub below_resolution: bool,
}

/// A bin of one dimension of the session, with the residual in it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Bin {
    /// `attack_angle_deg`, `depth_m`, `speed_rad_s` or `stroke`.
    pub dimension: &'static str,
    /// The bin's lower edge, in the dimension's unit.
    pub lo: f64,
    /// The bin's upper edge, in the dimension's unit.
    pub hi: f64,
    /// The bin as the report words it.
    pub label: String,
    /// Analysed points in the bin.
    pub samples: usize,
    /// Held-out RMSE in the bin over drag and lift (N).
    pub rmse_n: f64,
    /// Share of the gap (the squared residual in excess of the noise) in this bin, %.
    pub share_of_gap: f64,
    /// How far the bin's residual lies above the noise, as a z score.
    pub z: f64,
    /// Whether the bin's excess is beyond chance.
    pub significant: bool,
}

/// A candidate effect fitted alone on top of the baseline.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Candidate {
    /// The effect.
    pub effect: Effect,
    /// Fit on every stroke: `b_k`, `a`, the effect's parameters.
    pub params: BTreeMap<String, f64>,
    /// Its linear and nonlinear parameters' count, as the penalty counts them.
    pub parameters: usize,
    /// Held-out RMSE over drag and lift of the baseline alone (N).
    pub heldout_rmse_before_n: f64,
    /// Held-out RMSE with the effect's term (N).
    pub heldout_rmse_after_n: f64,
    /// Held-out goodness of fit with the effect's term, over drag and lift.
    pub heldout_psi_after: f64,
    /// Share of the gap closed, %; null when the gap is at the noise level (nothing to close).
    pub gap_closed_pct: Option<f64>,
    /// Held-out gain less the parameter penalty (N^2 per residual); <= 0: not worth its terms.
    pub penalized_gain_n2: f64,
    /// Paired t over strokes of the held-out improvement against the baseline alone.
    pub heldout_t: f64,
    /// Whether it improves the held-out strokes beyond chance on its own (t, penalty).
    pub significant: bool,
    /// Whether a direct signature of the session shows it (sensor_bias, sensor_lag).
    pub direct_evidence: bool,
}

/// An effect taken into the model, on top of the steps before it.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Step {
    /// The effect.
    pub effect: Effect,
    /// Fit on every stroke of the baseline with every effect so far: `b_k`, `a` (the medium's
    /// parameters once the effects are modelled), and the effects' parameters.
    pub params: BTreeMap<String, f64>,
    /// Share of the baseline's gap closed by all steps so far, %.
    pub gap_closed_pct: f64,
    /// Held-out RMSE over drag and lift with every step so far (N).
    pub heldout_rmse_n: f64,
    /// Held-out goodness of fit over drag and lift with every step so far.
    pub heldout_psi: f64,
    /// Share of the baseline's gap this step adds, %.
    pub share_of_gap_pct: f64,
    /// Paired t over strokes of this step's held-out improvement.
    pub heldout_t: f64,
    /// What kept the step: the held-out fit, the held-out fit and a direct signature, or the
    /// direct signature alone (a sensor effect the held-out fit cannot show).
    pub evidence: Evidence,
    /// With a direct signature: the share of the gap closed by correcting the session by the
    /// directly measured offset or delay and fitting the baseline again, %
    /// (a term fitted to the whole session can also take up part of the model's own misfit;
    /// this share cannot).
    pub direct_share_of_gap_pct: Option<f64>,
    /// For an effect that reaches only part of the session (`compaction` from its change on,
    /// `rate` above the session's lowest speed): the gap the baseline leaves on the strokes it
    /// does not reach, fitted to them alone, against the whole session's.
    pub contrast: Option<Contrast>,
    /// What shows the effect beyond its term closing part of the gap: a direct signature, a
    /// contrast between strokes, or nothing but the term's form.
    pub basis: Basis,
    /// What the step says of the robot and its medium, worded by its basis: a term found by its
    /// form alone is named for what it is, not for the cause it would have in another medium.
    pub claim: String,
}

/// What kept a step in the report (`report.json`: `held_out`, `held_out+direct`, `direct`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Evidence {
    /// Its held-out improvement is significant and material.
    #[serde(rename = "held_out")]
    HeldOut,
    /// That, and a direct signature of the session shows it as well.
    #[serde(rename = "held_out+direct")]
    HeldOutAndDirect,
    /// A sensor effect that a direct signature shows where the held-out fit cannot.
    #[serde(rename = "direct")]
    Direct,
}

impl Evidence {
    /// The name `report.json` gives it.
    pub fn name(self) -> &'static str {
        match self {
            Evidence::HeldOut => "held_out",
            Evidence::HeldOutAndDirect => "held_out+direct",
            Evidence::Direct => "direct",
        }
    }
}

impl std::fmt::Display for Evidence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.name())
    }
}

/// What a verdict names: the effect that closes the largest share of the gap, no gap beyond the
/// noise (`none`), or a gap no candidate explains (`unexplained`). `report.json` holds the
/// effect's name or one of the two words.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VerdictEffect {
    /// No gap beyond the noise.
    None,
    /// A gap no candidate explains.
    Unexplained,
    /// The effect that closes the largest share of the gap.
    Effect(Effect),
}

impl VerdictEffect {
    /// The name `report.json` gives it.
    pub fn name(self) -> &'static str {
        match self {
            VerdictEffect::None => "none",
            VerdictEffect::Unexplained => "unexplained",
            VerdictEffect::Effect(e) => e.name(),
        }
    }

    /// The effect it names, if any.
    pub fn effect(self) -> Option<Effect> {
        match self {
            VerdictEffect::Effect(e) => Some(e),
            _ => None,
        }
    }
}

impl std::fmt::Display for VerdictEffect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.name())
    }
}

impl serde::Serialize for VerdictEffect {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// What shows an effect, beyond its term closing part of the gap on held-out strokes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Basis {
    /// Force measured while the leg is out of the medium (a sensor offset).
    ForceOutOfMedium,
    /// The measured forces aligning with the predicted ones only when shifted later in time,
    /// or their onset moving later with speed (a delay).
    Alignment,
    /// The angle at which force first appears, against the predicted one (a surface level).
    OnsetAngle,
    /// The strokes the effect reaches against those it does not (a change over the session, a
    /// speed).
    Contrast,
    /// Nothing but the form of its term: it closes part of the gap, and another effect of the
    /// same form, or the model's own misfit, would do as well.
    FormOnly,
}

impl Basis {
    /// Its name as `report.json` writes it (`form_only`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Basis::ForceOutOfMedium => "force_out_of_medium",
            Basis::Alignment => "alignment",
            Basis::OnsetAngle => "onset_angle",
            Basis::Contrast => "contrast",
            Basis::FormOnly => "form_only",
        }
    }
}

impl std::fmt::Display for Basis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.pad(self.name())
    }
}

/// The session's own counterpart of an effect that reaches only some strokes.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Contrast {
    /// The strokes the effect does not reach (0-based).
    pub unreached_strokes: Vec<usize>,
    /// The baseline fitted to those strokes alone: its held-out RMS residual there (a single
    /// stroke's samples held out alternately), N.
    pub unreached_rmse_n: f64,
    /// The share of the whole session's gap in excess of what the baseline leaves on those
    /// strokes (both per sample in the medium), %: how much of the gap the effect accounts for,
    /// its term's form aside (the model's own misfit taken as on the strokes it does not
    /// reach).
    pub share_of_gap_pct: f64,
}

/// What the report names.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Verdict {
    /// The effect named, `none` or `unexplained`.
    pub effect: VerdictEffect,
    /// Share of the gap the named effect closes alone, %.
    pub gap_closed_pct: f64,
    /// Held-out Psi over drag and lift together, before the correction.
    pub heldout_psi_before: f64,
    /// Held-out Psi over drag and lift together after the correction.
    pub heldout_psi_after: f64,
    /// Share of the gap closed by all greedy steps, %.
    pub all_steps_gap_closed_pct: f64,
    /// The named effect's basis and what the report says of it (see [`Step::claim`]); none for
    /// `none` and `unexplained`.
    pub basis: Option<Basis>,
    /// What the report says of the named effect, worded by its basis.
    pub claim: String,
}

/// Per analysed point: angle, speed, measurement, held-out prediction before and after the
/// correction (after = all greedy steps; the baseline again when there are none).
#[derive(Debug, Clone)]
pub struct PlotData {
    /// Each analysed point's attack angle (rad).
    pub beta_rad: Vec<f64>,
    /// Each analysed point's angular speed (rad/s).
    pub speed_rad_s: Vec<f64>,
    /// Each point's measured drag and lift (N).
    pub measured_n: Vec<[f64; 2]>,
    /// Each point's held-out prediction of the baseline, drag and lift (N).
    pub before_n: Vec<[f64; 2]>,
    /// Each point's held-out prediction with every step, drag and lift (N).
    pub after_n: Vec<[f64; 2]>,
    /// The noise's variance over drag and lift (N^2).
    pub noise_var_n2: f64,
}

/// What every step of the analysis reads: the session, the options, the noise, the baseline
/// and the gap it leaves.
struct Ground<'a> {
    ctx: &'a Context,
    opts: &'a DiagnoseOptions,
    noise: Noise,
    /// The noise's variance over drag and lift (N^2).
    var: f64,
    base: Fit,
    /// The baseline's held-out mean squared residual (N^2).
    mse_b: f64,
    /// What of it lies beyond the noise (N^2).
    excess: f64,
    gap: Gap,
    /// The penalty on a held-out gain for each parameter a term adds (N^2).
    penalty_per_param: f64,
    signatures: Signatures,
    base_strokes: Vec<f64>,
    /// The paired t a gain must reach over the strokes.
    min_t: f64,
    length_m: f64,
}

impl Ground<'_> {
    /// The share of the gap (%) a held-out mean squared residual `mse` closes.
    fn closed(&self, mse: f64) -> f64 {
        if self.excess > 0.0 {
            100.0 * (self.mse_b - mse) / self.excess
        } else {
            0.0
        }
    }

    /// The signatures of the session read against `f`'s fit (the baseline's as read first).
    fn signatures_given(&self, f: &Fit, baseline: bool) -> Signatures {
        if baseline {
            return self.signatures.clone();
        }
        let mut sig = signatures::read(
            self.ctx,
            &f.fitted_n,
            [self.noise.drag_n, self.noise.lift_n],
        );
        // A late sensor moves the onset of force later the faster the leg, against any
        // prediction, and the baseline's does not depend on speed: where, against it, the onset
        // comes clearly earlier with speed, a delay read against a fit with speed terms (whose
        // own onset moves with speed) is that fit's, not the sensor's.
        if self.signatures.delay.onset_slope_t < -4.0 {
            sig.delay.significant = false;
        }
        sig
    }
}

/// The noise, the baseline fitted with held-out strokes, and whether the gap it leaves is real.
fn ground<'a>(ctx: &'a Context, opts: &'a DiagnoseOptions) -> Ground<'a> {
    let residuals = 2 * ctx.points.len();
    let noise = noise(ctx);
    let var = (0.5 * (noise.drag_n.powi(2) + noise.lift_n.powi(2))).max(1e-18);
    let base = fit(ctx, &Design::baseline(ctx.folds), None);
    let mse_b = base.heldout_mse();
    let excess = mse_b - var;
    let z = (base.heldout_sse / var - residuals as f64) / (2.0 * residuals as f64).sqrt();
    let gap_rms_n = excess.max(0.0).sqrt();
    let resolution_n = opts.min_gap_n.max(noise.quantum_n);
    let below_resolution = gap_rms_n <= resolution_n;
    let real = excess > opts.min_excess_ratio * var && z > 5.0 && !below_resolution;
    let signatures = signatures::read(ctx, &base.fitted_n, [noise.drag_n, noise.lift_n]);
    let base_strokes = stroke_sse(ctx, &base.heldout_n);
    // Significant: one-sided 5 % level of the paired t over the strokes that hold points.
    let min_t = t_critical_5pct(
        base_strokes
            .iter()
            .filter(|s| **s > 0.0)
            .count()
            .saturating_sub(1),
    );
    Ground {
        ctx,
        opts,
        noise,
        var,
        mse_b,
        excess,
        gap: Gap {
            real,
            heldout_mse_n2: mse_b,
            noise_var_n2: var,
            excess_ratio: excess / var,
            z,
            gap_rms_n,
            resolution_n,
            below_resolution,
        },
        penalty_per_param: opts.penalty * var * (residuals as f64).ln() / residuals as f64,
        signatures,
        base_strokes,
        min_t,
        length_m: ctx.model.plate().length_m(),
        base,
    }
}

/// Each effect alone on the baseline, scored on held-out strokes: the candidates, best
/// penalized gain first.
fn candidates(g: &Ground) -> Vec<(Fit, Candidate)> {
    let (ctx, real) = (g.ctx, g.gap.real);
    let mut fits: Vec<(Fit, Candidate)> = ALL
        .iter()
        .map(|&e| {
            let f = fit(ctx, &Design::baseline(ctx.folds), Some(e));
            let t = t_statistic(&improvements(
                &g.base_strokes,
                &stroke_sse(ctx, &f.heldout_n),
            ));
            let gain = g.mse_b - f.heldout_mse() - g.penalty_per_param * e.parameter_count() as f64;
            let c = Candidate {
                effect: e,
                params: params(&f),
                parameters: e.parameter_count(),
                heldout_rmse_before_n: g.mse_b.sqrt(),
                heldout_rmse_after_n: f.heldout_mse().sqrt(),
                heldout_psi_after: psi(ctx, &f.heldout_n),
                gap_closed_pct: real.then(|| g.closed(f.heldout_mse())),
                penalized_gain_n2: gain,
                heldout_t: t,
                significant: real && gain > 0.0 && t >= g.min_t,
                direct_evidence: direct(&g.signatures, e),
            };
            (f, c)
        })
        .collect();
    fits.sort_by(|a, b| b.1.penalized_gain_n2.total_cmp(&a.1.penalized_gain_n2));
    fits
}

/// What the selection of steps ends with.
struct Selection {
    steps: Vec<Step>,
    /// The fit with every step.
    current: Fit,
    /// The fit with every step whose terms stay within their physical bounds: the corrected
    /// model the node is given.
    admissible: Fit,
    /// The steps left out of it, by the effect they added, with why.
    left_out: Vec<(Option<Effect>, CorrectionsError)>,
    /// The effects not chosen in the last round, each with its share of what was left (%).
    remaining: Vec<(Effect, f64)>,
}

impl Selection {
    /// `f` becomes the admissible model where its terms stay within their bounds; else its step
    /// is left out, with why.
    fn admit(&mut self, g: &Ground, f: &Fit) {
        match corrected_model(g.ctx, f).validate(g.length_m) {
            Ok(()) => self.admissible = f.clone(),
            Err(e) => self.left_out.push((f.design.effects.last().copied(), e)),
        }
    }
}

/// Forward selection on held-out strokes: each round adds the effect with the largest held-out
/// gain over the effects chosen so far that is significant (its gain holds stroke by stroke:
/// paired t over strokes, and it pays for its parameters) and material (it closes a set share
/// of the gap, or a direct signature of the session shows it). Then the sensor effects whose
/// direct signature holds, given everything modelled.
fn select(g: &Ground, fits: &[(Fit, Candidate)]) -> Selection {
    let (ctx, opts, var, excess) = (g.ctx, g.opts, g.var, g.excess);
    let closed = |mse: f64| g.closed(mse);
    let mut sel = Selection {
        steps: Vec::new(),
        current: g.base.clone(),
        admissible: g.base.clone(),
        left_out: Vec::new(),
        remaining: Vec::new(),
    };
    while g.gap.real && sel.steps.len() < opts.max_steps {
        let current = &sel.current;
        let mse = current.heldout_mse();
        let cur_strokes = stroke_sse(ctx, &current.heldout_n);
        let sig_now = g.signatures_given(current, sel.steps.is_empty());
        let mut tried: Vec<(Fit, f64, f64)> = ALL
            .iter()
            .filter(|e| !current.design.effects.contains(e))
            .map(|&e| {
                let f = if current.design.effects.is_empty() {
                    fits.iter()
                        .find(|(f, _)| f.design.effects == [e])
                        .map(|x| x.0.clone())
                } else {
                    None
                }
                .unwrap_or_else(|| fit(ctx, &current.design, Some(e)));
                let t = t_statistic(&improvements(&cur_strokes, &stroke_sse(ctx, &f.heldout_n)));
                let gain = mse - f.heldout_mse() - g.penalty_per_param * e.parameter_count() as f64;
                (f, gain, t)
            })
            .collect();
        tried.sort_by(|a, b| b.1.total_cmp(&a.1));
        sel.remaining = tried
            .iter()
            .map(|(f, _, _)| {
                let e = *f.design.effects.last().expect("one effect was added");
                let left = mse - var;
                (
                    e,
                    if left > 0.0 {
                        100.0 * (mse - f.heldout_mse()) / left
                    } else {
                        0.0
                    },
                )
            })
            .collect();
        let chosen = tried.into_iter().find(|(f, gain, t)| {
            let e = *f.design.effects.last().expect("one effect was added");
            let share = 100.0 * (mse - f.heldout_mse()) / excess;
            *gain > 0.0 && *t >= g.min_t && (share >= opts.step_pct || direct(&sig_now, e))
        });
        let Some((next, _, t)) = chosen else { break };
        let e = *next.design.effects.last().expect("one effect was added");
        let seen = direct(&sig_now, e);
        sel.steps.push(Step {
            evidence: if seen {
                Evidence::HeldOutAndDirect
            } else {
                Evidence::HeldOut
            },
            direct_share_of_gap_pct: seen
                .then(|| direct_share(ctx, e, &sig_now, var, excess))
                .flatten(),
            contrast: contrast(ctx, &next, e, var, excess),
            ..step(ctx, &next, mse, t, &closed, excess)
        });
        sel.admit(g, &next);
        sel.current = next;
        sel.remaining.clear();
        if sel.current.heldout_mse() - var <= opts.min_excess_ratio * var {
            break;
        }
    }
    // A sensor effect whose direct signature holds, given everything modelled, is reported even
    // where the held-out fit cannot show it: the model's own misfit can mask a delay (a model
    // that lags the medium in angle looks better once the sensor lags too).
    if g.gap.real {
        let sig_end = g.signatures_given(&sel.current, sel.steps.is_empty());
        for e in ALL.into_iter().filter(|e| e.is_sensor()) {
            if sel.current.design.effects.contains(&e) || !direct(&sig_end, e) {
                continue;
            }
            let mse = sel.current.heldout_mse();
            let f = fit(ctx, &sel.current.design, Some(e));
            let t = t_statistic(&improvements(
                &stroke_sse(ctx, &sel.current.heldout_n),
                &stroke_sse(ctx, &f.heldout_n),
            ));
            sel.steps.push(Step {
                evidence: Evidence::Direct,
                direct_share_of_gap_pct: direct_share(ctx, e, &sig_end, var, excess),
                ..step(ctx, &f, mse, t, &closed, excess)
            });
            if f.heldout_mse() < mse {
                sel.admit(g, &f);
                sel.current = f;
            }
        }
    }
    for st in &mut sel.steps {
        st.basis = basis_of(st, &g.signatures);
        st.claim = claim(st.effect, st.basis, opts.cohesive_medium);
    }
    sel
}

/// The verdict: the significant effect with the largest share of the gap, if that share is
/// material; otherwise `unexplained` (a real gap) or `none`.
fn verdict(g: &Ground, fits: &[(Fit, Candidate)], sel: &Selection) -> Verdict {
    let psi_before = psi(g.ctx, &g.base.heldout_n);
    let named = sel
        .steps
        .iter()
        .max_by(|a, b| a.share_of_gap_pct.total_cmp(&b.share_of_gap_pct))
        .filter(|s| s.share_of_gap_pct >= g.opts.accept_pct);
    let all_closed = sel.steps.last().map_or(0.0, |s| s.gap_closed_pct);
    let real = g.gap.real;
    match named {
        Some(st) => {
            let alone = fits
                .iter()
                .find(|(_, c)| c.effect == st.effect)
                .map(|(_, c)| c)
                .expect("every effect has a candidate");
            Verdict {
                effect: VerdictEffect::Effect(st.effect),
                gap_closed_pct: alone.gap_closed_pct.unwrap_or(0.0),
                heldout_psi_before: psi_before,
                heldout_psi_after: alone.heldout_psi_after,
                all_steps_gap_closed_pct: all_closed,
                basis: Some(st.basis),
                claim: st.claim.clone(),
            }
        }
        None => Verdict {
            effect: if real {
                VerdictEffect::Unexplained
            } else {
                VerdictEffect::None
            },
            gap_closed_pct: fits
                .first()
                .and_then(|b| b.1.gap_closed_pct)
                .unwrap_or(0.0)
                .max(0.0),
            heldout_psi_before: psi_before,
            heldout_psi_after: if sel.steps.is_empty() {
                psi_before
            } else {
                psi(g.ctx, &sel.current.heldout_n)
            },
            all_steps_gap_closed_pct: all_closed,
            basis: None,
            claim: if real {
                "an effect no candidate term explains, or the model's own misfit".into()
            } else if g.gap.below_resolution {
                format!(
                    "no gap to explain: {:.3} N beyond the noise, within what the sensor resolves ({:.3} N)",
                    g.gap.gap_rms_n, g.gap.resolution_n
                )
            } else {
                "no gap to explain: the model fits to the noise level".into()
            },
        },
    }
}

/// The corrected model the node is given, with what the report says of it.
struct CorrectedParts {
    model: Corrections,
    std: Option<CorrectedStd>,
    fit_samples: usize,
    refit_refused: Option<String>,
    gap_closed_pct: f64,
    forward_gap_closed_pct: Option<f64>,
    left_out: Vec<String>,
}

/// The corrected model of the admissible steps: a step left out because its fit, built on an
/// earlier step's, left the bounds is tried again on the admissible model alone, and the chosen
/// terms are fitted again on every sample of `fit_ctx`.
fn corrected(g: &Ground, fit_ctx: Option<&Context>, sel: &Selection) -> CorrectedParts {
    let (ctx, length_m) = (g.ctx, g.length_m);
    // A term that stays physical beside the kept ones and predicts the held-out strokes better
    // is kept (on DEM strokes of rising speed, `rate` beside a cohesion-like term, once a
    // surcharge step before it had fitted a negative b_k).
    let mut admissible = sel.admissible.clone();
    for e in sel.steps.iter().map(|st| st.effect) {
        if admissible.design.effects.contains(&e) {
            continue;
        }
        let f = fit(ctx, &admissible.design, Some(e));
        if corrected_model(ctx, &f).validate(length_m).is_ok()
            && f.heldout_mse() < admissible.heldout_mse()
        {
            admissible = f;
        }
    }
    let left_out = sel
        .left_out
        .iter()
        .filter(|(e, _)| e.is_none_or(|e| !admissible.design.effects.contains(&e)))
        .map(|(e, why)| format!("{} ({why})", e.map_or("baseline", Effect::name)))
        .collect();
    // The chosen terms with the nonlinear values the search chose, fitted again on every
    // sample: `b_k`, `a` and the coefficients. Without terms the corrected model is the
    // report's baseline, as the search fitted it.
    let refit = fit_ctx
        .filter(|_| !admissible.design.effects.is_empty())
        .map(|full| {
            let design = Design {
                effects: admissible.design.effects.clone(),
                fixed: admissible.nonlinear.clone(),
            };
            let f = fit(full, &design, None);
            let c = corrected_model(full, &f);
            c.validate(length_m)
                .map(|()| (c, corrected_std(&f), full.points.len()))
                .map_err(|e| e.to_string())
        });
    let (model, std, fit_samples, refit_refused) = match refit {
        Some(Ok((c, std, fitted_on))) => (c, std, fitted_on, None),
        other => (
            corrected_model(ctx, &admissible),
            corrected_std(&admissible),
            ctx.points.len(),
            other.and_then(Result::err),
        ),
    };
    CorrectedParts {
        model,
        std,
        fit_samples,
        refit_refused,
        gap_closed_pct: g.closed(admissible.heldout_mse()),
        forward_gap_closed_pct: g
            .opts
            .forward_share
            .then(|| forward_gap_closed_pct(ctx, &admissible, g.var))
            .flatten(),
        left_out,
    }
}

/// What of a real gap every step leaves, where it lies and which effects it resembles.
fn unexplained(g: &Ground, sel: &Selection) -> Option<Unexplained> {
    g.gap.real.then(|| {
        let left = sel.current.heldout_mse() - g.var;
        let mut resembles: Vec<Resemblance> = sel
            .remaining
            .iter()
            .filter(|(_, pct)| *pct > 0.0)
            .map(|&(effect, pct)| Resemblance {
                effect,
                share_of_remaining_pct: pct,
            })
            .collect();
        resembles.truncate(3);
        Unexplained {
            share_of_gap_pct: (100.0 * left / g.excess).clamp(0.0, 100.0),
            heldout_rmse_n: sel.current.heldout_mse().sqrt(),
            where_: where_left(where_bins(g.ctx, &sel.current.heldout_n, g.var)),
            resembles,
        }
    })
}

pub(super) fn analyse(
    ctx: &Context,
    fit_ctx: Option<&Context>,
    opts: &DiagnoseOptions,
    skipped: usize,
    samples_given: usize,
) -> Diagnosis {
    let g = ground(ctx, opts);
    let fits = candidates(&g);
    let sel = select(&g, &fits);
    let verdict = verdict(&g, &fits, &sel);
    let corrected = corrected(&g, fit_ctx, &sel);
    let unexplained = unexplained(&g, &sel);
    let where_ = where_bins(ctx, &g.base.heldout_n, g.var);
    let baseline = Baseline {
        b_k: g.base.coefficients[0],
        a: g.base.a,
        psi_drag: psi_component(ctx, &g.base.heldout_n, 0),
        psi_lift: psi_component(ctx, &g.base.heldout_n, 1),
        rmse_n: g.mse_b.sqrt(),
    };
    let candidates: Vec<Candidate> = fits.into_iter().map(|(_, c)| c).collect();
    let summary = summary(
        &g.gap,
        &where_,
        &candidates,
        &sel.steps,
        &verdict,
        &g.noise,
        unexplained.as_ref(),
    );
    Diagnosis {
        report: Report {
            samples: samples_given,
            analysed: ctx.points.len(),
            skipped_non_finite: skipped,
            strokes: ctx.strokes,
            folds: ctx.folds,
            noise: g.noise.clone(),
            baseline,
            gap: g.gap.clone(),
            where_,
            candidates,
            steps: sel.steps,
            verdict,
            summary,
            unexplained,
            signatures: g.signatures.clone(),
            corrected_model: corrected.model,
            corrected_model_gap_closed_pct: corrected.gap_closed_pct,
            corrected_model_forward_gap_closed_pct: corrected.forward_gap_closed_pct,
            corrected_model_left_out: corrected.left_out,
            corrected_model_std: corrected.std,
            corrected_model_fit_samples: corrected.fit_samples,
            corrected_model_refit_refused: corrected.refit_refused,
            hip_placed_points: ctx
                .points
                .iter()
                .filter(|p| p.hip_height_m.is_some())
                .count(),
        },
        plot: PlotData {
            beta_rad: ctx.points.iter().map(|p| p.beta_rad).collect(),
            speed_rad_s: ctx.points.iter().map(|p| p.speed_rad_s).collect(),
            measured_n: ctx.points.iter().map(|p| p.y_n).collect(),
            before_n: g.base.heldout_n.clone(),
            after_n: sel.current.heldout_n,
            noise_var_n2: g.var,
        },
    }
}

/// The share of the gap (over the noise variance `var`) that the design of `f` closes on the
/// last third of the session's strokes, fitted on the strokes before them with `f`'s nonlinear
/// values (see `Report::corrected_model_forward_gap_closed_pct`).
fn forward_gap_closed_pct(ctx: &Context, f: &Fit, var: f64) -> Option<f64> {
    if f.design.effects.is_empty() || ctx.strokes < 3 {
        return None;
    }
    let first_test = ctx.strokes - (ctx.strokes / 3).max(1);
    let split = ctx.forward_split(first_test);
    let whole = f.nonlinear.last().copied().unwrap_or_default();
    let design = Design {
        effects: f.design.effects.clone(),
        fixed: vec![whole; split.folds + 1],
    };
    let test_mse = |g: &Fit| {
        let (sse, n) = split
            .points
            .iter()
            .zip(&g.heldout_n)
            .filter(|(p, _)| p.fold == 0)
            .fold((0.0, 0usize), |(sse, n), (p, h)| {
                (
                    sse + (p.y_n[0] - h[0]).powi(2) + (p.y_n[1] - h[1]).powi(2),
                    n + 2,
                )
            });
        (n > 0).then(|| sse / n as f64)
    };
    let bare = test_mse(&fit(&split, &Design::baseline(split.folds), None))?;
    let corrected = test_mse(&fit(&split, &design, None))?;
    let excess = bare - var;
    (excess > 0.0).then(|| 100.0 * (bare - corrected) / excess)
}

/// The corrected model of the fit `f` on every stroke.
pub(crate) fn corrected_model(ctx: &Context, f: &Fit) -> Corrections {
    let mut c = Corrections::none(f.coefficients[0], f.a);
    let mut j = 1;
    for &e in &f.design.effects {
        let n = e.linear_params().len();
        c.terms.push(Term {
            effect: e,
            coefficients: f.coefficients[j..j + n].to_vec(),
        });
        j += n;
    }
    c.nonlinear = f.nonlinear.last().copied().unwrap_or_default();
    c.typical_speed_rad_s = ctx.typical_speed_rad_s();
    c.session_strokes = ctx.strokes;
    c
}

/// The step that `f` (the design so far and its last effect) makes from a held-out mean squared
/// residual `mse_before`, its evidence held out only.
fn step(
    ctx: &Context,
    f: &Fit,
    mse_before: f64,
    t: f64,
    closed: &dyn Fn(f64) -> f64,
    excess: f64,
) -> Step {
    Step {
        effect: *f.design.effects.last().expect("a step adds an effect"),
        params: params(f),
        gap_closed_pct: closed(f.heldout_mse()),
        heldout_rmse_n: f.heldout_mse().sqrt(),
        heldout_psi: psi(ctx, &f.heldout_n),
        share_of_gap_pct: 100.0 * (mse_before - f.heldout_mse()) / excess,
        heldout_t: t,
        evidence: Evidence::HeldOut,
        direct_share_of_gap_pct: None,
        contrast: None,
        basis: Basis::FormOnly,
        claim: String::new(),
    }
}

/// Strokes as runs of consecutive numbers: `0-2, 5`.
fn stroke_list(strokes: &[usize]) -> String {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for &k in strokes {
        match runs.last_mut() {
            Some((_, hi)) if *hi + 1 == k => *hi = k,
            _ => runs.push((k, k)),
        }
    }
    let label = |(lo, hi): (usize, usize)| {
        if lo == hi {
            lo.to_string()
        } else {
            format!("{lo}-{hi}")
        }
    };
    let list: Vec<String> = runs.into_iter().map(label).collect();
    format!(
        "stroke{} {}",
        if strokes.len() == 1 { "" } else { "s" },
        list.join(", ")
    )
}

/// Speeds of strokes this close to the session's lowest count as the lowest.
const LOWEST_SPEED_BAND: f64 = 1.25;

/// The strokes an effect does not reach in fit `f` (where it reaches only some), and the
/// baseline's gap on them (see [`Contrast`]).
fn contrast(ctx: &Context, f: &Fit, e: Effect, var: f64, excess: f64) -> Option<Contrast> {
    let strokes = ctx.strokes.max(1);
    let unreached: Vec<usize> = match e {
        Effect::Compaction => {
            let at = f.nonlinear.last()?.change_at_session_frac;
            let mut before = vec![true; strokes];
            for p in &ctx.points {
                before[p.stroke.min(strokes - 1)] &= p.session_frac < at - 1e-9;
            }
            (0..strokes).filter(|&s| before[s]).collect()
        }
        Effect::Rate => {
            // The strokes near the lowest speed, where the session's speeds span a factor two.
            let stroke_speed = ctx.stroke_speeds_rad_s(1);
            let lo = lowest_of_twofold_span(stroke_speed.iter().flatten().copied())?;
            (0..strokes)
                .filter(|&s| stroke_speed[s].is_some_and(|m| m <= LOWEST_SPEED_BAND * lo))
                .collect()
        }
        _ => return None,
    };
    if unreached.is_empty() || unreached.len() == strokes || excess <= 0.0 {
        return None;
    }
    // The unreached strokes as a session of their own (one stroke: nothing to hold out but
    // noise, so its samples alternate between two folds).
    let folds = unreached.len().clamp(2, ctx.folds.max(2));
    let sub = ctx.sub_session(&unreached, folds);
    let mse = fit(&sub, &Design::baseline(folds), None).heldout_mse();
    // Both gaps per sample in the medium: out of it the baseline predicts no force, and the
    // strokes differ in how long they spend in the air.
    let per_in_medium = |c: &Context, gap: f64| {
        let frac = c.in_medium_frac();
        (frac > 0.0).then(|| gap / frac)
    };
    let unreached_gap = per_in_medium(&sub, mse - var)?;
    let whole_gap = per_in_medium(ctx, excess)?;
    mse.is_finite().then(|| Contrast {
        unreached_strokes: unreached,
        unreached_rmse_n: mse.sqrt(),
        share_of_gap_pct: 100.0 * (1.0 - unreached_gap / whole_gap),
    })
}

/// The share of the gap closed by correcting the session by a directly measured effect and
/// fitting the baseline again (see [`Step::direct_share_of_gap_pct`]).
fn direct_share(ctx: &Context, e: Effect, sig: &Signatures, var: f64, excess: f64) -> Option<f64> {
    let design = Design::baseline(ctx.folds);
    let mut corrected = ctx.clone();
    match e {
        Effect::SensorBias => {
            let off = [sig.sensor_offset.drag_n, sig.sensor_offset.lift_n];
            for p in &mut corrected.points {
                p.y_n = [p.y_n[0] - off[0], p.y_n[1] - off[1]];
            }
        }
        Effect::SensorLag => {
            let times: Vec<f64> = ctx.points.iter().map(|p| p.t_s).collect();
            let y: Vec<[f64; 2]> = ctx.points.iter().map(|p| p.y_n).collect();
            for p in &mut corrected.points {
                p.y_n = signatures::interpolate(&times, &y, p.t_s + sig.delay.lag_s);
            }
        }
        _ => return None,
    }
    (excess > 0.0).then(|| {
        let mse = fit(&corrected, &design, None).heldout_mse();
        100.0 * (1.0 - (mse - var) / excess)
    })
}

/// Where what is left lies: in each of attack angle, depth, speed and stroke, its two largest
/// significant bins (largest share first).
fn where_left(bins: Vec<Bin>) -> Vec<Bin> {
    let mut out: Vec<Bin> = Vec::new();
    for dim in ["attack_angle_deg", "depth_m", "speed_rad_s", "stroke"] {
        out.extend(
            bins.iter()
                // A speed bin of one speed says nothing of where (a session at one speed).
                .filter(|b| b.dimension == dim && b.significant && b.share_of_gap > 0.0)
                .filter(|b| b.dimension != "speed_rad_s" || b.hi > b.lo * (1.0 + 1e-6))
                .take(2)
                .cloned(),
        );
    }
    out.sort_by(|a, b| b.share_of_gap.total_cmp(&a.share_of_gap));
    out
}

/// Whether a direct signature of the session shows `e`.
/// Only the sensor's effects: the onset is reported in the signatures but does not vouch for
/// `hip_height`, because the model's own misfit shifts it too.
fn direct(sig: &Signatures, e: Effect) -> bool {
    match e {
        Effect::SensorBias => sig.sensor_offset.significant,
        Effect::SensorLag => sig.delay.significant,
        _ => false,
    }
}

/// Held-out squared residual per stroke.
fn stroke_sse(ctx: &Context, pred: &[[f64; 2]]) -> Vec<f64> {
    let mut out = vec![0.0; ctx.strokes.max(1)];
    for (p, q) in ctx.points.iter().zip(pred) {
        out[p.stroke.min(ctx.strokes.max(1) - 1)] +=
            (p.y_n[0] - q[0]).powi(2) + (p.y_n[1] - q[1]).powi(2);
    }
    out
}

/// Per-stroke reduction of the squared residual, over the strokes that hold points.
fn improvements(before: &[f64], after: &[f64]) -> Vec<f64> {
    before
        .iter()
        .zip(after)
        .filter(|(b, _)| **b > 0.0)
        .map(|(b, a)| b - a)
        .collect()
}

/// Sensor noise per component, robust (1.4826 x median absolute deviation).
fn noise(ctx: &Context) -> Noise {
    let out: Vec<&Point> = ctx.out_of_medium(0.35).collect();
    if out.len() >= 100 {
        let d: Vec<f64> = out.iter().map(|p| p.y_n[0]).collect();
        let l: Vec<f64> = out.iter().map(|p| p.y_n[1]).collect();
        return Noise {
            drag_n: mad_sigma(&d),
            lift_n: mad_sigma(&l),
            source: "out_of_medium",
            samples: out.len(),
            quantum_n: quantum(ctx),
        };
    }
    let diff = |c: usize| -> Vec<f64> {
        ctx.points
            .windows(2)
            .map(|w| (w[1].y_n[c] - w[0].y_n[c]) / std::f64::consts::SQRT_2)
            .collect()
    };
    Noise {
        drag_n: mad_sigma(&diff(0)),
        lift_n: mad_sigma(&diff(1)),
        source: "successive_differences",
        samples: ctx.points.len(),
        quantum_n: quantum(ctx),
    }
}

/// The sensor's quantisation step: the smallest step between distinct values of a component,
/// the larger over drag and lift (0 with fewer than two distinct values).
fn quantum(ctx: &Context) -> f64 {
    let step = |c: usize| {
        let mut v: Vec<f64> = ctx.points.iter().map(|p| p.y_n[c]).collect();
        v.sort_by(f64::total_cmp);
        v.windows(2)
            .map(|w| w[1] - w[0])
            .filter(|d| *d > 0.0)
            .fold(f64::INFINITY, f64::min)
    };
    [step(0), step(1)]
        .into_iter()
        .filter(|q| q.is_finite())
        .fold(0.0, f64::max)
}

fn mad_sigma(x: &[f64]) -> f64 {
    let med = median(x);
    let dev: Vec<f64> = x.iter().map(|v| (v - med).abs()).collect();
    1.4826 * median(&dev)
}

/// Psi (Eq. 28) over drag and lift together.
fn psi(ctx: &Context, pred: &[[f64; 2]]) -> f64 {
    let (num, den) = psi_sums(ctx, pred, 0);
    let (num_l, den_l) = psi_sums(ctx, pred, 1);
    if den + den_l > 0.0 {
        1.0 - (num + num_l) / (den + den_l)
    } else {
        0.0
    }
}

fn psi_component(ctx: &Context, pred: &[[f64; 2]], c: usize) -> f64 {
    let (num, den) = psi_sums(ctx, pred, c);
    if den > 0.0 { 1.0 - num / den } else { 0.0 }
}

/// Squared residuals and squared measurements of component `c`.
fn psi_sums(ctx: &Context, pred: &[[f64; 2]], c: usize) -> (f64, f64) {
    ctx.points
        .iter()
        .zip(pred)
        .fold((0.0, 0.0), |(num, den), (p, q)| {
            (num + (p.y_n[c] - q[c]).powi(2), den + p.y_n[c].powi(2))
        })
}

fn params(f: &Fit) -> BTreeMap<String, f64> {
    let mut m = BTreeMap::new();
    m.insert("b_k".to_string(), f.coefficients[0]);
    m.insert("a".to_string(), f.a);
    let mut j = 1;
    for e in &f.design.effects {
        for name in e.linear_params() {
            m.insert(
                name.to_string(),
                f.coefficients.get(j).copied().unwrap_or(0.0),
            );
            j += 1;
        }
        if let Some(name) = e.nonlinear_param() {
            m.insert(
                name.to_string(),
                f.nonlinear.last().map_or(0.0, |v| v.get(*e)),
            );
        }
    }
    m
}

/// The held-out squared residual by bins of each dimension.
fn where_bins(ctx: &Context, pred: &[[f64; 2]], var: f64) -> Vec<Bin> {
    let sq: Vec<f64> = ctx
        .points
        .iter()
        .zip(pred)
        .map(|(p, q)| (p.y_n[0] - q[0]).powi(2) + (p.y_n[1] - q[1]).powi(2))
        .collect();
    let total_excess: f64 = sq.iter().map(|s| s - 2.0 * var).sum::<f64>().max(1e-300);
    let mut bins = Vec::new();
    let mut add = |dimension: &'static str,
                   lo: f64,
                   hi: f64,
                   label: String,
                   members: &dyn Fn(&Point) -> bool| {
        let (mut k, mut s) = (0usize, 0.0);
        for (p, e) in ctx.points.iter().zip(&sq) {
            if members(p) {
                k += 1;
                s += e;
            }
        }
        if k == 0 {
            return;
        }
        let z = (s / var - 2.0 * k as f64) / (4.0 * k as f64).sqrt();
        bins.push(Bin {
            dimension,
            lo,
            hi,
            label,
            samples: k,
            rmse_n: (s / (2 * k) as f64).sqrt(),
            share_of_gap: 100.0 * (s - 2.0 * k as f64 * var) / total_excess,
            z,
            significant: z > 4.0,
        });
    };
    for i in 0..18 {
        let (lo, hi) = (10.0 * i as f64, 10.0 * (i + 1) as f64);
        add(
            "attack_angle_deg",
            lo,
            hi,
            format!("{lo:.0}-{hi:.0} deg"),
            &|p| {
                let d = p.beta_rad.to_degrees();
                p.in_medium() && d >= lo && d < hi
            },
        );
    }
    let max_depth = ctx.model.plate().max_depth_m();
    for i in 0..5 {
        let (lo, hi) = (max_depth * i as f64 / 5.0, max_depth * (i + 1) as f64 / 5.0);
        add(
            "depth_m",
            lo,
            hi,
            format!("{:.0}-{:.0} mm", lo * 1e3, hi * 1e3),
            &|p| p.in_medium() && p.depth_m > lo && p.depth_m <= hi + 1e-12,
        );
    }
    for (dimension, value, unit) in [
        (
            "speed_rad_s",
            (|p: &Point| p.speed_rad_s) as fn(&Point) -> f64,
            "rad/s",
        ),
        ("accel_rad_s2", |p: &Point| p.accel_rad_s2, "rad/s^2"),
    ] {
        let inside: Vec<f64> = ctx
            .points
            .iter()
            .filter(|p| p.in_medium())
            .map(value)
            .collect();
        let edges = quantile_edges(&inside, 5);
        for w in edges.windows(2) {
            let (lo, hi) = (w[0], w[1]);
            add(dimension, lo, hi, format!("{lo:.2}-{hi:.2} {unit}"), &|p| {
                let v = value(p);
                p.in_medium() && v >= lo && (v < hi || hi == *edges.last().unwrap_or(&hi))
            });
        }
    }
    for r in [Regime::Penetration, Regime::Extraction, Regime::OutOfMedium] {
        let code = f64::from(r.code());
        add("regime", code, code, r.as_str().to_string(), &|p| match r {
            Regime::Extraction => p.extraction(),
            other => p.regime == other,
        });
    }
    let strokes = ctx.strokes.max(1);
    let per = strokes.div_ceil(5).max(1);
    for i in (0..strokes).step_by(per) {
        let (lo, hi) = (i, (i + per).min(strokes));
        add(
            "stroke",
            lo as f64,
            hi as f64,
            format!("strokes {lo}-{}", hi - 1),
            &|p| p.stroke >= lo && p.stroke < hi,
        );
    }
    bins.sort_by(|a, b| b.share_of_gap.total_cmp(&a.share_of_gap));
    bins
}

fn quantile_edges(x: &[f64], bins: usize) -> Vec<f64> {
    if x.is_empty() {
        return Vec::new();
    }
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    let mut e: Vec<f64> = (0..=bins).map(|i| v[((v.len() - 1) * i) / bins]).collect();
    e.dedup();
    e
}

fn summary(
    gap: &Gap,
    where_: &[Bin],
    cands: &[Candidate],
    steps: &[Step],
    v: &Verdict,
    noise: &Noise,
    unexplained: Option<&Unexplained>,
) -> String {
    let rmse = (gap.heldout_mse_n2).sqrt();
    let sigma = gap.noise_var_n2.sqrt();
    let mut s = format!(
        "On strokes it was not fitted to, the baseline model misses the measured forces by {rmse:.2} N (RMS), against sensor noise of {sigma:.2} N measured {}. ",
        if noise.source == "out_of_medium" {
            "while the leg was out of the medium"
        } else {
            "from sample-to-sample differences"
        }
    );
    if gap.below_resolution {
        s += &format!(
            "Beyond the noise that is {:.3} N, within what the sensor resolves ({:.3} N: {}): no gap to explain (verdict: none).",
            gap.gap_rms_n,
            gap.resolution_n,
            if noise.quantum_n >= gap.resolution_n {
                "its quantisation step"
            } else {
                "the stated floor, --min-gap-n"
            }
        );
        return s;
    }
    if !gap.real {
        s += "That is at the noise level: no gap to explain, and no unmodelled effect is needed for this session (verdict: none).";
        return s;
    }
    let hot: Vec<&Bin> = where_
        .iter()
        .filter(|b| b.significant && b.dimension == "attack_angle_deg")
        .take(3)
        .collect();
    if !hot.is_empty() {
        s += &format!(
            "The gap sits mostly at attack angles {} ({:.0} % of it). ",
            hot.iter()
                .map(|b| b.label.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            hot.iter().map(|b| b.share_of_gap).sum::<f64>()
        );
    }
    if !steps.is_empty() {
        s += &format!(
            "Significant on held-out strokes: {}. ",
            steps
                .iter()
                .map(|st| format!(
                    "{}: {}, {:.0} % of the gap",
                    named(st.effect, &st.claim),
                    st.claim,
                    st.share_of_gap_pct,
                ))
                .collect::<Vec<_>>()
                .join("; ")
        );
    }
    if v.effect != VerdictEffect::Unexplained {
        s += &format!(
            "The largest is {}: alone it closes {:.0} % of the gap, and held-out Psi goes from {:.3} to {:.3}.",
            v.effect
                .effect()
                .map_or(v.effect.to_string(), |e| named(e, &v.claim)),
            v.gap_closed_pct,
            v.heldout_psi_before,
            v.heldout_psi_after
        );
        if steps.len() > 1 {
            s += &format!(
                " All {} together close {:.0} %.",
                steps.len(),
                v.all_steps_gap_closed_pct
            );
        }
    } else if steps.is_empty() {
        s += &format!(
            "No candidate correction is significant and material (the best, {}, closes {:.0} %): the gap comes from an effect outside the library (verdict: unexplained).",
            cands.first().map_or("none", |c| c.effect.name()),
            v.gap_closed_pct
        );
    } else {
        s += &format!(
            "None of them closes a material share of the gap on its own (verdict: unexplained); together they close {:.0} %.",
            v.all_steps_gap_closed_pct
        );
    }
    for st in steps {
        if let Some(c) = &st.contrast {
            s += &format!(
                " Against the strokes {} does not reach ({}), fitted alone, it accounts for {:.0} % of the gap.",
                st.effect,
                stroke_list(&c.unreached_strokes),
                c.share_of_gap_pct
            );
        }
    }
    if let Some(u) = unexplained.filter(|u| u.share_of_gap_pct >= 5.0) {
        s += &format!(
            " {:.0} % of the gap is left unexplained (the model's own misfit or an effect outside the library)",
            u.share_of_gap_pct
        );
        let places: Vec<String> = u
            .where_
            .iter()
            .take(3)
            .map(|b| match b.dimension {
                "attack_angle_deg" => format!("attack angle {}", b.label),
                "depth_m" => format!("depth {}", b.label),
                "speed_rad_s" => format!("speed {}", b.label),
                _ => b.label.clone(),
            })
            .collect();
        if !places.is_empty() {
            s += &format!(", mostly at {}", places.join(", "));
        }
        if let Some(r) = u.resembles.first() {
            s += &format!(
                "; it resembles {} ({}), whose term would close {:.0} % of it, not enough to claim it",
                r.effect,
                describe(r.effect),
                r.share_of_remaining_pct
            );
        }
        s += ".";
    }
    s
}

/// What shows step `st`'s effect beyond its term's form.
fn basis_of(st: &Step, sig: &Signatures) -> Basis {
    match st.effect {
        Effect::SensorBias if st.evidence != Evidence::HeldOut => Basis::ForceOutOfMedium,
        Effect::SensorLag if st.evidence != Evidence::HeldOut => Basis::Alignment,
        Effect::HipHeight if sig.onset.significant => Basis::OnsetAngle,
        Effect::Compaction | Effect::Rate if st.contrast.is_some() => Basis::Contrast,
        _ => Basis::FormOnly,
    }
}

/// What a step found on `basis` says of the robot and its medium. A cohesion term found by its
/// form alone, in a medium not described as cohesive, is a strength proportional to the
/// submerged area and no more: the model's own misfit takes that form too (it does on the
/// non-cohesive DEM beds).
fn claim(e: Effect, basis: Basis, cohesive_medium: bool) -> String {
    let seen = match basis {
        Basis::ForceOutOfMedium => {
            "seen directly: force measured while the leg is out of the medium"
        }
        Basis::Alignment => "seen directly: the forces align with the model only shifted later",
        Basis::OnsetAngle => "seen directly: force appears at another angle than predicted",
        Basis::Contrast => "seen in the strokes it reaches against those it does not",
        Basis::FormOnly => "by the form of its term alone",
    };
    match (e, basis, cohesive_medium) {
        (Effect::Cohesion, Basis::FormOnly, false) => format!(
            "{}: cohesion, or the model's own misfit ({seen}; the medium was not described as cohesive)",
            describe(e)
        ),
        (Effect::Cohesion, _, true) => format!(
            "cohesion: {}, in a medium described as cohesive ({seen})",
            describe(e)
        ),
        _ => format!("{} ({seen})", describe(e)),
    }
}

/// How a summary names a step's effect: by its claim where the claim is not the effect's name.
fn named(e: Effect, claim: &str) -> String {
    if e == Effect::Cohesion && !claim.starts_with("cohesion:") {
        "a cohesion-like term".into()
    } else {
        e.name().into()
    }
}

fn describe(e: Effect) -> &'static str {
    match e {
        Effect::Rate => "resistance growing with speed",
        Effect::Inertia => "a force following the leg's angular acceleration",
        Effect::Surcharge => "grains piling up ahead of the leg as it sweeps",
        Effect::Extraction => "the extraction phase behaving unlike the passive model",
        Effect::Compaction => "the medium's strength changing over the session",
        Effect::Cohesion => "a strength proportional to the submerged area",
        Effect::HipHeight => "the surface at another level than the configured hip height",
        Effect::SensorBias => "a constant offset of the F/T sensor",
        Effect::SensorLag => "the F/T signal lagging the joint angles",
    }
}
