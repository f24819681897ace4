//! Property tests: over random valid geometry, media and angles, no model panics or returns NaN.

use proptest::prelude::*;
use terzaghi::model::{
    FittingWidth, Medium, ModelError, Plate, RftCoefficients, RftFit, RftModel, TerzaghiModel,
};

fn finite_or_overflow(
    r: Result<terzaghi::model::TerzaghiForce, ModelError>,
) -> Result<(), TestCaseError> {
    match r {
        Ok(f) => {
            for v in [
                f.drag_n,
                f.lift_n,
                f.hip_torque_nm,
                f.normal_n,
                f.submerged_m,
                f.depth_m,
                f.terms.g_lg_n,
                f.terms.d_lg_m,
                f.terms.g_t_n,
                f.terms.f_l_n,
            ] {
                prop_assert!(v.is_finite(), "{f:?}");
            }
            prop_assert!(f.submerged_m >= 0.0 && f.depth_m >= -1e-15);
            Ok(())
        }
        Err(ModelError::Overflow { .. }) => Ok(()),
        Err(e) => Err(TestCaseError::fail(format!("unexpected error {e}"))),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn terzaghi_never_nan_nor_panic(
        l in 0.001f64..5.0, b in 0.001f64..1.0, h_frac in 0.0f64..1.5,
        lambda in 100.0f64..30000.0, phi in 0.01f64..89.99, delta in 0.0f64..89.99,
        b_k in 1e-3f64..1e3, a in 1e-2f64..1e2, beta in -50.0f64..50.0,
    ) {
        let plate = Plate::new(l, b, h_frac * l).unwrap();
        let m = TerzaghiModel::new(plate, Medium::new(lambda, phi, delta).unwrap(), FittingWidth::new(b_k, a).unwrap());
        let r = m.evaluate(beta);
        // Realistic media never overflow.
        if phi <= 60.0 {
            prop_assert!(r.is_ok(), "{r:?}");
        }
        finite_or_overflow(r)?;
    }

    #[test]
    fn rft_never_nan_nor_panic(
        l in 0.001f64..5.0, b in 0.001f64..1.0, h_frac in 0.0f64..1.5,
        beta in -50.0f64..50.0, n in 1usize..300, grid in any::<bool>(),
    ) {
        let plate = Plate::new(l, b, h_frac * l).unwrap();
        let c = if grid { RftCoefficients::by_name("poppy_lp_grid", None).unwrap() } else { RftCoefficients::Fit(RftFit::POPPY_CP) };
        let p = RftModel::new(plate, c, n).unwrap().evaluate(beta).unwrap();
        prop_assert!(p.drag_n.is_finite() && p.lift_n.is_finite() && p.hip_torque_nm.is_finite());
    }

    #[test]
    fn invalid_inputs_are_errors_not_panics(
        l in prop::num::f64::ANY, b in prop::num::f64::ANY, h in prop::num::f64::ANY,
        w in prop::num::f64::ANY, phi in prop::num::f64::ANY, delta in prop::num::f64::ANY,
        b_k in prop::num::f64::ANY, a in prop::num::f64::ANY, beta in prop::num::f64::ANY,
    ) {
        if let (Ok(p), Ok(m), Ok(fw)) = (Plate::new(l, b, h), Medium::new(w, phi, delta), FittingWidth::new(b_k, a)) {
            let r = TerzaghiModel::new(p, m, fw).evaluate(beta);
            if beta.is_finite() {
                finite_or_overflow(r)?;
            } else {
                prop_assert!(r.is_err());
            }
        }
    }
}
