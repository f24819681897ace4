//! The node's online identification of a corrected model against the batch diagnosis, on the
//! generated sessions of `terzaghi-eval diagnose-eval --online` (the generator of `withheld`, whose
//! effects are written in forms of their own): learnt from the conventional start (`b_k = a = 1`,
//! every coefficient 0) with the node's default options.

mod common;

use terzaghi_eval::closed_loop::{
    LearntOnline, ONLINE_CASES, STEP_CASES, STEP_FACTOR, learnt_online, learnt_step,
};

const SEED: u64 = 1;

fn table(c: &LearntOnline) -> String {
    let mut s = format!(
        "{} ({}): converged {}, {} changes\n",
        c.case, c.truth, c.converged, c.changes_detected
    );
    for v in &c.values {
        s += &format!(
            "  {:<34} batch {:>12.5e} online {:>12.5e} +- {:>9.2e} ({:+.1} %, determined {})\n",
            v.name,
            v.batch,
            v.online,
            v.std,
            v.diff_pct(),
            v.determined()
        );
    }
    s
}

/// In every session, one hidden effect each, the online values reach the batch values within
/// 10 % (every value the session determines, `b_k` and `a` always), converged at the end.
#[test]
fn corrections_learnt_online_reach_the_batch_diagnosis() {
    let all: Vec<LearntOnline> = ONLINE_CASES
        .map(|i| learnt_online(i, SEED).unwrap())
        .collect();
    for c in &all {
        print!("{}", table(c));
    }
    // The cases that hold, each with at least one coefficient beside b_k and a to check, or
    // the surface level moving the baseline.
    for truth in ["cohesion", "hip_height", "sensor_bias", "sensor_lag"] {
        let c = all.iter().find(|c| c.truth == truth).unwrap();
        assert!(c.holds(), "{}", table(c));
        assert!(c.values.iter().filter(|v| v.determined()).count() >= 2);
    }
    assert!(
        all.iter()
            .any(|c| c.values.iter().filter(|v| v.determined()).count() >= 4 && c.holds()),
        "no case checks coefficients beside b_k and a"
    );
    // No session has a step of the medium: the change alarms that the terms' misfit in some
    // strokes raises are dismissed, and none restarts the estimate.
    for c in &all {
        assert_eq!(c.changes_detected, 0, "{}", table(c));
    }
    assert!(
        all.iter().map(|c| c.alarms_dismissed).sum::<u64>() >= 3,
        "the sessions raise no alarm to dismiss"
    );
    // Compaction too: its change in the session is learnt over the session's strokes, none of
    // them forgotten, and its nearly collinear coefficients converge on the force they predict.
    let failing: Vec<&str> = all
        .iter()
        .filter(|c| !c.holds())
        .map(|c| c.truth.as_str())
        .collect();
    assert!(failing.is_empty(), "update the README: {failing:?}");
}

/// A medium 1.4 times as strong after the session: the change is detected within a stroke and
/// the values reach the batch diagnosis of the stronger part within 10 %.
#[test]
fn a_step_of_the_medium_is_followed() {
    for i in STEP_CASES {
        let s = learnt_step(i, SEED, STEP_FACTOR).unwrap();
        print!(
            "detected after {:?} strokes\n{}{}",
            s.detected_after_strokes,
            table(&s.before),
            table(&s.after)
        );
        // Followed everywhere: the baseline's b_k within 10 % of the stronger part's.
        let b_k = &s.after.values[0];
        assert!(b_k.within_10_pct(), "{}", table(&s.after));
        if ["cohesion", "sensor_bias"].contains(&s.before.truth.as_str()) {
            assert!(s.before.holds(), "{}", table(&s.before));
            assert!(s.after.holds(), "{}", table(&s.after));
            let after = s.detected_after_strokes.unwrap();
            assert!(
                (0.0..1.0).contains(&after),
                "detected after {after} strokes"
            );
        }
    }
}

/// Through the node's core, as a recording of the session: a leg whose `corrections` start from
/// scratch publishes the learnt coefficients in `model_params` and predicts with them once
/// converged, as well as with the batch diagnosis's on the session's last third.
#[test]
fn the_node_learns_its_corrections_and_predicts_with_them() {
    use terzaghi::config::{LegConfig, NodeConfig};
    use terzaghi::diagnose::{DiagnoseOptions, diagnose};
    use terzaghi::model::TerzaghiModel;
    use terzaghi::session::reevaluate::{Output, Row, reevaluate_samples_with};
    use terzaghi::sim::generator::Hidden;
    let (case, samples) = ONLINE_CASES
        .clone()
        .map(|i| terzaghi_eval::withheld::case_session(i, SEED))
        .find(|(case, _)| case.effects == [Hidden::Cohesion])
        .unwrap();
    let model = TerzaghiModel::conventional(case.plate, case.medium);
    let batch = diagnose(&model, &samples, &DiagnoseOptions::default())
        .unwrap()
        .report
        .corrected_model;
    let scratch = batch.unlearnt();
    let t_end = samples.last().unwrap().t_s.unwrap();
    let run = |corrections, learn: bool| {
        let mut leg = LegConfig::new("leg", "leg", case.plate, case.medium);
        leg.corrections = Some(corrections);
        let mut cfg = NodeConfig::with_legs(vec![leg], "joint_states").unwrap();
        cfg.use_identified = learn;
        let (mut sq, mut n) = (0.0, 0);
        let mut last = None;
        reevaluate_samples_with(
            &samples,
            cfg,
            0,
            |r: &Row| {
                if r.t_s > t_end * 2.0 / 3.0 {
                    sq += (r.measured_drag_n.unwrap() - r.expected_reading_drag_n).powi(2)
                        + (r.measured_lift_n.unwrap() - r.expected_reading_lift_n).powi(2);
                    n += 2;
                }
            },
            |o| {
                if let Output::Params(_, _, p) = o {
                    last = Some(p.clone());
                }
            },
        )
        .unwrap();
        ((sq / n as f64).sqrt(), last.unwrap())
    };
    let (learnt, params) = run(scratch.clone(), true);
    let (with_batch, _) = run(batch.clone(), false);
    let (unlearnt, _) = run(scratch, false);
    println!(
        "last third: RMSE {learnt:.3} N learnt online, {with_batch:.3} N with the batch values, {unlearnt:.3} N from scratch unlearnt; {params:?}"
    );
    assert!(params.converged);
    assert_eq!(
        params.correction_params,
        ["cohesion.normal_pa", "cohesion.tangential_pa"]
    );
    let batch_values = &batch.terms[0].coefficients;
    for ((v, s), b) in params
        .correction_values
        .iter()
        .zip(&params.correction_stds)
        .zip(batch_values)
    {
        assert!((v - b).abs() <= 0.1 * b.abs(), "{v} against {b}");
        assert!(s.is_finite() && *s > 0.0);
    }
    assert!((params.b_k - batch.b_k).abs() <= 0.1 * batch.b_k);
    assert!(learnt <= 1.05 * with_batch, "{learnt} against {with_batch}");
    assert!(learnt < 0.5 * unlearnt, "{learnt} against {unlearnt}");
}
