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

// The hand-written readers and writers of a session agree with the crates they stand beside.
mod agree_with_the_crates {
    use proptest::prelude::*;
    use terzaghi::model::Regime;
    use terzaghi::msgs::{
        DecodeInto, Header, JointState, Time, Vector3, Wrench, WrenchStamped, from_cdr, to_cdr,
    };
    use terzaghi::session::csv_rows::{CSV_HEADER, CsvRows};
    use terzaghi::session::reevaluate::Row;

    fn any_f64() -> impl Strategy<Value = f64> {
        prop_oneof![
            any::<f64>(),
            -1e3f64..1e3,
            Just(0.0),
            Just(-0.0),
            Just(f64::NAN),
            Just(f64::INFINITY)
        ]
    }

    fn joint_state() -> impl Strategy<Value = JointState> {
        (
            any::<i32>(),
            0u32..1_000_000_000,
            "[a-z_]{0,12}",
            prop::collection::vec("[a-z_0-9]{0,16}", 0..8),
            prop::collection::vec(any_f64(), 0..8),
            prop::collection::vec(any_f64(), 0..8),
            prop::collection::vec(any_f64(), 0..4),
        )
            .prop_map(
                |(sec, nanosec, frame_id, name, position, velocity, effort)| JointState {
                    header: Header {
                        stamp: Time { sec, nanosec },
                        frame_id,
                    },
                    name,
                    position,
                    velocity,
                    effort,
                },
            )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]

        /// DecodeInto reads what cdr_encoding reads, into a message that held another one, and
        /// fails where it fails on every cut of the bytes.
        #[test]
        fn decode_into_agrees_with_cdr_encoding(m in joint_state(), before in joint_state(),
                                                f in prop::array::uniform6(any_f64())) {
            let bytes = to_cdr(&m).unwrap();
            let mut held = before;
            held.decode_into(&bytes).unwrap();
            let serde: JointState = from_cdr(&bytes).unwrap();
            prop_assert_eq!(format!("{held:?}"), format!("{serde:?}"));
            for cut in [0, 3, 4, bytes.len() / 2, bytes.len().saturating_sub(1)] {
                prop_assert_eq!(
                    JointState::default().decode_into(&bytes[..cut]).is_ok(),
                    from_cdr::<JointState>(&bytes[..cut]).is_ok()
                );
            }
            let w = WrenchStamped {
                header: m.header.clone(),
                wrench: Wrench {
                    force: Vector3 { x: f[0], y: f[1], z: f[2] },
                    torque: Vector3 { x: f[3], y: f[4], z: f[5] },
                },
            };
            let bytes = to_cdr(&w).unwrap();
            let mut held = WrenchStamped::default();
            held.decode_into(&bytes).unwrap();
            prop_assert_eq!(format!("{held:?}"), format!("{:?}", from_cdr::<WrenchStamped>(&bytes).unwrap()));
        }

        /// message_records hands on the message records mcap's LinearReader reads, in order.
        #[test]
        fn message_records_agree_with_mcap(
            messages in prop::collection::vec(
                (any::<u16>(), any::<u32>(), any::<u64>(), any::<u64>(),
                 prop::collection::vec(any::<u8>(), 0..64)),
                0..40),
            other_at in prop::collection::vec(0usize..40, 0..5),
        ) {
            let mut records = Vec::new();
            let mut push = |op: u8, body: &[u8]| {
                records.push(op);
                records.extend_from_slice(&(body.len() as u64).to_le_bytes());
                records.extend_from_slice(body);
            };
            for (i, (channel, seq, log, publish, data)) in messages.iter().enumerate() {
                if other_at.contains(&i) {
                    // A metadata-like record the reader passes over.
                    let mut body = Vec::new();
                    for s in ["name", ""] {
                        body.extend_from_slice(&(s.len() as u32).to_le_bytes());
                        body.extend_from_slice(s.as_bytes());
                    }
                    body.extend_from_slice(&0u32.to_le_bytes());
                    push(0x0C, &body);
                }
                let mut body = Vec::new();
                body.extend_from_slice(&channel.to_le_bytes());
                body.extend_from_slice(&seq.to_le_bytes());
                body.extend_from_slice(&log.to_le_bytes());
                body.extend_from_slice(&publish.to_le_bytes());
                body.extend_from_slice(data);
                push(0x05, &body);
            }
            let mut ours = Vec::new();
            terzaghi::record::read::message_records(&records, |c, l, p, d| {
                ours.push((c, l, p, d.to_vec()))
            })
            .unwrap();
            let mut theirs = Vec::new();
            for r in mcap::read::LinearReader::sans_magic(&records) {
                if let mcap::records::Record::Message { header, data } = r.unwrap() {
                    theirs.push((header.channel_id, header.log_time, header.publish_time, data.to_vec()));
                }
            }
            prop_assert_eq!(ours, theirs);
        }

        /// Rows written by CsvRows read back with the csv crate, field for field and float for
        /// float (bit for bit, NaN as NaN).
        #[test]
        fn csv_rows_read_back_with_the_csv_crate(
            legs in prop::collection::vec("[a-z ,\"_]{1,10}", 1..4),
            values in prop::collection::vec(
                (any::<usize>(), prop::array::uniform16(any_f64()), any::<bool>(), any::<bool>(), 0usize..5),
                1..60),
        ) {
            let mut rows = CsvRows::new(&legs).unwrap();
            let mut text = CSV_HEADER.as_bytes().to_vec();
            let written: Vec<Row> = values
                .iter()
                .map(|(leg, v, measured, identified, regime)| Row {
                    t_s: v[0],
                    leg: leg % legs.len(),
                    beta_rad: v[1],
                    regime: Regime::ALL[*regime],
                    measured_drag_n: measured.then_some(v[2]),
                    measured_lift_n: measured.then_some(v[3]),
                    predicted_drag_n: v[4],
                    predicted_lift_n: v[5],
                    predicted_hip_torque_nm: v[6],
                    b_k: v[7],
                    a: v[8],
                    identified: *identified,
                    bare_drag_n: v[9],
                    bare_lift_n: v[10],
                    expected_reading_drag_n: v[11],
                    expected_reading_lift_n: v[12],
                    predicted_side_n: v[13],
                    predicted_roll_moment_nm: v[14],
                    predicted_yaw_moment_nm: v[15],
                })
                .collect();
            for r in &written {
                rows.push(&mut text, r);
            }
            let mut rdr = csv::Reader::from_reader(&text[..]);
            let back: Vec<csv::StringRecord> = rdr.records().map(|r| r.unwrap()).collect();
            prop_assert_eq!(back.len(), written.len());
            let same = |field: &str, v: f64| {
                let b: f64 = field.parse().unwrap();
                b.to_bits() == v.to_bits() || (b.is_nan() && v.is_nan())
            };
            for (b, w) in back.iter().zip(&written) {
                prop_assert_eq!(b.len(), 19);
                prop_assert!(same(&b[0], w.t_s));
                prop_assert_eq!(&b[1], legs[w.leg].as_str());
                prop_assert!(same(&b[2], w.beta_rad));
                prop_assert_eq!(&b[3], w.regime.as_str());
                match (w.measured_drag_n, w.measured_lift_n) {
                    (Some(d), Some(l)) => prop_assert!(same(&b[4], d) && same(&b[5], l)),
                    _ => prop_assert!(b[4].is_empty() && b[5].is_empty()),
                }
                for (i, v) in [(6, w.predicted_drag_n), (7, w.predicted_lift_n),
                               (8, w.predicted_hip_torque_nm), (9, w.b_k), (10, w.a)] {
                    prop_assert!(same(&b[i], v), "field {} of {:?}", i, b);
                }
                prop_assert_eq!(&b[11], if w.identified { "true" } else { "false" });
                for (i, v) in [(12, w.bare_drag_n), (13, w.bare_lift_n),
                               (14, w.expected_reading_drag_n), (15, w.expected_reading_lift_n),
                               (16, w.predicted_side_n), (17, w.predicted_roll_moment_nm),
                               (18, w.predicted_yaw_moment_nm)] {
                    prop_assert!(same(&b[i], v), "field {} of {:?}", i, b);
                }
            }
        }
    }
}
