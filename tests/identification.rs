//! Batch identification through the real binary on files on disk.

use rand::SeedableRng;
use rand::rngs::StdRng;
use std::process::Command;
use terzaghi::ident::Sample;
use terzaghi::model::{
    FittingWidth, Medium, Plate, RftCoefficients, RftFit, RftModel, TerzaghiModel,
};
use terzaghi::sim;

fn fit_json(csv: &str, extra: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("data.csv");
    std::fs::write(&path, csv).unwrap();
    let mut args = vec![
        "fit",
        path.to_str().unwrap(),
        "--length-m",
        "0.25",
        "--width-m",
        "0.06",
        "--hip-height-m",
        "0.15",
        "--json",
    ];
    args.extend(extra);
    let out = Command::new(env!("CARGO_BIN_EXE_terzaghi"))
        .args(&args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn recovers_bk_and_a_within_2_percent_from_noisy_model_data() {
    let plate = Plate::new(0.25, 0.06, 0.15).unwrap();
    let truth = TerzaghiModel::new(
        plate,
        Medium::new(16170.0, 32.0, 19.0).unwrap(),
        FittingWidth::new(2.0, 1.5).unwrap(),
    );
    for seed in 0..5 {
        let mut rng = StdRng::seed_from_u64(seed);
        let angles = sim::rotate(&sim::Rotation::default(), 4, &mut rng);
        let samples = sim::measure(&angles, 0.02, &mut rng, |_, b| {
            let f = truth.evaluate(b).unwrap();
            (f.drag_n, f.lift_n)
        });
        let v = fit_json(
            &sim::to_csv(&samples),
            &[
                "--unit-weight-n-m3",
                "16170",
                "--phi-deg",
                "32",
                "--delta-deg",
                "19",
            ],
        );
        let (b_k, a) = (v["b_k"].as_f64().unwrap(), v["a"].as_f64().unwrap());
        eprintln!(
            "seed {seed}: b_k {b_k:.4} a {a:.4} from {} samples",
            v["samples"]
        );
        assert!((b_k / 2.0 - 1.0).abs() < 0.02, "seed {seed}: b_k {b_k}");
        assert!((a / 1.5 - 1.0).abs() < 0.02, "seed {seed}: a {a}");
        for key in [
            "psi_drag",
            "psi_lift",
            "r2_drag",
            "r2_lift",
            "rmse_drag_n",
            "rmse_lift_n",
        ] {
            assert!(
                v["improved"][key].is_f64() && v["conventional"][key].is_f64(),
                "{key}"
            );
        }
    }
}

/// The paper's claim, against RFT as the reference: the improved model fits, the conventional does not.
#[test]
fn improved_model_fits_rft_poppy_seeds_and_conventional_does_not() {
    let plate = Plate::new(0.25, 0.06, 0.15).unwrap();
    for (medium, coeffs) in [
        ("poppy_lp", RftFit::POPPY_LP),
        ("poppy_cp", RftFit::POPPY_CP),
    ] {
        let rft = RftModel::new(plate, RftCoefficients::Fit(coeffs), 100).unwrap();
        let samples: Vec<Sample> = (0..=100)
            .map(|i| {
                let beta = (40.0 + 0.5 * i as f64).to_radians();
                let p = rft.evaluate(beta).unwrap();
                Sample {
                    t_s: None,
                    beta_rad: beta,
                    drag_n: p.drag_n,
                    lift_n: p.lift_n,
                }
            })
            .collect();
        let v = fit_json(&sim::to_csv(&samples), &["--medium", medium, "--fit-delta"]);
        let psi = |m: &str, k: &str| v[m][k].as_f64().unwrap();
        eprintln!(
            "{medium}: improved psi {:.4}/{:.4}, conventional {:.4}/{:.4}, b_k {}, a {}, delta {}",
            psi("improved", "psi_drag"),
            psi("improved", "psi_lift"),
            psi("conventional", "psi_drag"),
            psi("conventional", "psi_lift"),
            v["b_k"],
            v["a"],
            v["delta_deg"]
        );
        assert!(
            psi("improved", "psi_drag") >= 0.97 && psi("improved", "psi_lift") >= 0.97,
            "{medium}"
        );
        assert!(
            psi("conventional", "psi_drag") < psi("improved", "psi_drag") - 0.1,
            "{medium}"
        );
    }
}
