//! Criterion benchmarks of one model evaluation: `cargo bench --bench model`.

use criterion::{Criterion, black_box, criterion_group, criterion_main};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
use terzaghi::model::{
    Body, BodyLeg, FittingWidth, ForceModel, Grousers, HipMotion, Medium, Plate, RftCoefficients,
    RftFit, RftModel, RftSpeedLaw, TerzaghiModel, c_leg_profile,
};

fn models(c: &mut Criterion) {
    let plate = Plate::new(0.25, 0.06, 0.15).unwrap();
    let improved = TerzaghiModel::new(
        plate,
        Medium::new(16170.0, 32.0, 19.0).unwrap(),
        FittingWidth::new(2.0, 1.5).unwrap(),
    );
    let rft = RftModel::new(plate, RftCoefficients::Fit(RftFit::POPPY_LP), 100).unwrap();
    let beta = 70f64.to_radians();
    c.bench_function("improved_terzaghi_evaluate", |b| {
        b.iter(|| improved.evaluate(black_box(beta)).unwrap().drag_n)
    });
    c.bench_function("rft_100_elements_evaluate", |b| {
        b.iter(|| rft.evaluate(black_box(beta)).unwrap().drag_n)
    });
    // RHex's C-leg as the node predicts it (`<leg>.shape: c_leg`, a half circle on a 100 mm
    // chord in 32 segments, the node's default of 100 elements), its hip 40 mm up and moving
    // as a walking robot's does.
    let c_leg_model = |law: Option<RftSpeedLaw>| {
        ForceModel::Rft(
            RftModel::with_profile(
                Plate::new(0.1, 0.03, 0.04).unwrap(),
                RftCoefficients::Fit(RftFit::POPPY_LP),
                100,
                c_leg_profile(0.05, std::f64::consts::PI, 32),
            )
            .unwrap()
            .with_speed_law(law),
        )
    };
    let c_leg = c_leg_model(None);
    let hip = HipMotion {
        height_m: 0.04,
        pitch_rad: 0.02,
        omega_rad_s: 5.0,
        forward_m_s: 0.1,
        up_m_s: -0.05,
        forward_position_m: 0.0,
        lateral_m_s: 0.0,
    };
    c.bench_function("rft_c_leg_evaluate", |b| {
        b.iter(|| c_leg.predict_moving(black_box(beta), &hip).unwrap().drag_n)
    });
    // The same leg with its hip moving sideways too (a robot turning): each element's planar
    // stress weighted by its share of speed in the plane, plus the shear across it.
    let turning = HipMotion {
        lateral_m_s: 0.05,
        ..hip
    };
    c.bench_function("rft_c_leg_sideways_evaluate", |b| {
        b.iter(|| {
            c_leg
                .predict_moving(black_box(beta), &turning)
                .unwrap()
                .side_n
        })
    });
    // The same leg with RFT's speed law (the DEM medium's, `launch_configs/dem_cleg.yaml`: a
    // gain per direction of motion, from straight up to straight down).
    let c_leg_speed = c_leg_model(Some(
        RftSpeedLaw::by_direction(
            0.05,
            &[
                (-FRAC_PI_2, 0.0292),
                (-FRAC_PI_4, 0.0145),
                (0.0, 0.0274),
                (FRAC_PI_4, 0.0282),
                (FRAC_PI_2, 0.0376),
            ],
            0.8,
        )
        .unwrap(),
    ));
    c.bench_function("rft_c_leg_speed_law_evaluate", |b| {
        b.iter(|| {
            c_leg_speed
                .predict_moving(black_box(beta), &hip)
                .unwrap()
                .drag_n
        })
    });
    // The same leg with a medium calibrated from intrusion tests (the DEM bed's file: Li's nine
    // coefficients measured, a law in depth with its surface offset, the speed law).
    let measured = terzaghi::medium_file::MediumFile::read(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/dem/campaign/medium_from_intrusions.yaml"
    )))
    .unwrap()
    .rft_law(None)
    .unwrap();
    let c_leg_measured = ForceModel::Rft(
        RftModel::with_profile(
            Plate::new(0.1, 0.03, 0.04).unwrap(),
            measured.coefficients,
            100,
            c_leg_profile(0.05, std::f64::consts::PI, 32),
        )
        .unwrap()
        .with_depth_law(Some(measured.depth_law))
        .with_speed_law(measured.speed_law),
    );
    c.bench_function("rft_c_leg_measured_medium_evaluate", |b| {
        b.iter(|| {
            c_leg_measured
                .predict_moving(black_box(beta), &hip)
                .unwrap()
                .drag_n
        })
    });
    // A wheel leg (`<leg>.shape: wheel`): the shared real wheel (radius 58 mm, width 50 mm,
    // 360 rim elements, the node's default) in the plate runs' medium, 25 mm deep, rolling
    // with slip 0.5; pressed straight down; and with 8 grousers 10 mm high, turned.
    let plate_runs = terzaghi::medium_file::MediumFile::read(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/medium_without_shape.yaml"
    )))
    .unwrap()
    .rft_law(None)
    .unwrap();
    let wheel = |g: Option<Grousers>| {
        ForceModel::Body(Box::new(BodyLeg::new(
            Body::wheel(0.058, 0.05, g, 360).unwrap(),
            plate_runs.coefficients.clone(),
            Some(plate_runs.depth_law),
            None,
            Plate::new(0.058, 0.05, 0.033).unwrap(),
        )))
    };
    let rolling = HipMotion {
        height_m: 0.033,
        omega_rad_s: 0.345,
        forward_m_s: 0.01,
        ..HipMotion::default()
    };
    // Rolling as above with the hub moving sideways too (a slip angle of 27 degrees): every
    // element of the rim across its width and of the side faces, in three dimensions.
    let sideways = HipMotion {
        lateral_m_s: 0.005,
        ..rolling
    };
    let pressed = HipMotion {
        height_m: 0.033,
        up_m_s: -0.003,
        ..HipMotion::default()
    };
    let smooth = wheel(None);
    let grousered = wheel(Some(Grousers {
        count: 8,
        height_m: 0.01,
        thickness_m: 0.004,
    }));
    // A mesh body's cost per triangle: a sphere foot (radius 30 mm, 15 mm deep, dragged and
    // sinking) of 4 m (m - 1) triangles for m rings, one element per triangle: 224, 960 and
    // 3,968 triangles.
    for rings in [8, 16, 32] {
        let sphere = Body::sphere(0.03, [0.0; 3], rings, 1.0).unwrap();
        let hub = terzaghi::model::HubMotion {
            height_m: 0.015,
            velocity_m_s: [0.01, 0.0, -0.002],
            ..Default::default()
        };
        let name = format!(
            "body_mesh_sphere_{}_triangles_forces",
            sphere.element_count()
        );
        c.bench_function(&name, |b| {
            b.iter(|| {
                black_box(&sphere).forces(
                    &plate_runs.coefficients,
                    Some(&plate_runs.depth_law),
                    None,
                    black_box(&hub),
                )
            })
        });
    }
    // A batch of 4,096 x 6 C-legs (96 elements, chord 0.125 m) in the plate runs' medium (its
    // law in depth: a power per element in the sand), as a learning user's environments give
    // them: angles over the turn, hips 0-12 cm up (about half the legs in the sand).
    {
        use terzaghi::model::batch::{LegForcesOut, LegKernel, Legs};
        let kernel = LegKernel::new(ForceModel::Rft(
            RftModel::with_profile(
                Plate::new(0.125, 0.03, 0.06).unwrap(),
                plate_runs.coefficients.clone(),
                96,
                c_leg_profile(0.0625, std::f64::consts::PI, 32),
            )
            .unwrap()
            .with_depth_law(Some(plate_runs.depth_law)),
        ));
        let n = 4096 * 6;
        let col = |f: &dyn Fn(f64) -> f64| -> Vec<f64> {
            (0..n)
                .map(|i| f((i as f64 * 0.618_033_988_75).fract()))
                .collect()
        };
        let beta = col(&|u| (2.0 * u - 1.0) * std::f64::consts::PI);
        let h = col(&|u| 0.12 * ((u * 7.0).fract()));
        let (pitch, omega, fwd, up) = (vec![0.0; n], vec![1.0; n], vec![0.1; n], vec![0.0; n]);
        let (mut drag, mut lift, mut torque) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        c.bench_function("batch_c_legs_4096x6_plate_runs_medium", |b| {
            b.iter(|| {
                kernel
                    .forces(
                        &Legs::moving([&beta, &h, &pitch, &omega, &fwd, &up]),
                        0,
                        LegForcesOut {
                            drag_n: &mut drag,
                            lift_n: &mut lift,
                            hip_torque_nm: &mut torque,
                        },
                    )
                    .unwrap();
                black_box(lift[7])
            })
        });
    }
    for (name, model, hip) in [
        ("body_wheel_rolling_evaluate", &smooth, &rolling),
        ("body_wheel_pressed_evaluate", &smooth, &pressed),
        ("body_wheel_grousers_rolling_evaluate", &grousered, &rolling),
        ("body_wheel_sideways_evaluate", &smooth, &sideways),
    ] {
        c.bench_function(name, |b| {
            b.iter(|| model.predict_moving(black_box(0.3), hip).unwrap())
        });
    }
}

/// The legs of `launch_configs/rhex.yaml`.
const RHEX_LEGS: [&str; 6] = [
    "front_left",
    "middle_left",
    "rear_left",
    "front_right",
    "middle_right",
    "rear_right",
];

/// One online-estimator update with a penetration sample, past the start-up.
fn online_update(c: &mut Criterion) {
    use terzaghi::ident::{OnlineEstimator, OnlineOptions, Sample};
    let model = TerzaghiModel::new(
        Plate::new(0.25, 0.06, 0.15).unwrap(),
        Medium::new(16170.0, 32.0, 19.0).unwrap(),
        FittingWidth::new(2.0, 1.5).unwrap(),
    );
    let samples: Vec<Sample> = (0..256)
        .map(|i| {
            let beta = 0.7 + 0.85 * i as f64 / 255.0;
            let f = model.evaluate(beta).unwrap();
            let wobble = 0.3 * ((i * 7919) % 13) as f64 / 13.0 - 0.15;
            Sample {
                t_s: None,
                beta_rad: beta,
                drag_n: f.drag_n + wobble,
                lift_n: f.lift_n - wobble,
            }
        })
        .collect();
    let mut est = OnlineEstimator::new(&model, OnlineOptions::default()).unwrap();
    for s in samples.iter().cycle().take(1000) {
        let _ = est.update(s);
    }
    let mut i = 0;
    c.bench_function("online_update", |b| {
        b.iter(|| {
            i = (i + 1) % samples.len();
            est.update(black_box(&samples[i])).is_ok()
        })
    });
}

/// One online update of a corrected leg past its start-up: the robot's front-left leg with the
/// corrections of `rhex_corrected_config` (surcharge, extraction, rate and the sensor's lag:
/// eleven values learnt), fed a stroke of its own corrected forces with a wobble.
fn online_update_corrected(c: &mut Criterion) {
    use terzaghi::ident::{CorrectedEstimator, OnlineOptions, Sample};
    use terzaghi::model::corrections::{CorrectedModel, MOTION_WINDOW_S, MotionTracker};
    let cfg = rhex_corrected_config();
    let leg = &cfg.legs[0];
    let model =
        CorrectedModel::new(leg.plate, leg.medium, leg.corrections.clone().unwrap()).unwrap();
    let (omega, dt) = (4.0, 0.001);
    let mut tracker = MotionTracker::new(MOTION_WINDOW_S);
    let stroke: Vec<_> = (0..(std::f64::consts::TAU / omega / dt) as usize)
        .map(|i| {
            let (t, beta) = (i as f64 * dt, i as f64 * dt * omega);
            let sub = leg.plate.submerged_length_m(beta);
            let m = tracker.update(t, beta, sub, leg.plate.length_m());
            let p = model.evaluate(beta, &m).unwrap();
            let wobble = 0.3 * ((i * 7919) % 13) as f64 / 13.0 - 0.15;
            (beta, m, p.drag_n + wobble, p.lift_n - wobble)
        })
        .collect();
    let mut est = CorrectedEstimator::new(model, OnlineOptions::default()).unwrap();
    let mut k = 0usize;
    let mut next = move || {
        let (beta, m, d, l) = stroke[k % stroke.len()];
        let turns = (k / stroke.len()) as f64;
        let s = Sample {
            t_s: Some(k as f64 * dt),
            beta_rad: beta + turns * std::f64::consts::TAU,
            drag_n: d,
            lift_n: l,
        };
        k += 1;
        (s, m)
    };
    for _ in 0..20_000 {
        let (s, m) = next();
        let _ = est.update(&s, &m);
    }
    c.bench_function("online_update_corrected", |b| {
        b.iter(|| {
            let (s, m) = next();
            est.update(black_box(&s), &m).is_ok()
        })
    });
}

criterion_group!(benches, models, online_update, online_update_corrected);
criterion_main!(benches, node);

/// The node's configuration for the six-legged robot of `launch_configs/rhex.yaml`.
fn rhex_config() -> terzaghi::config::NodeConfig {
    rhex_config_with("")
}

/// The same robot with corrections on every leg, as a diagnosis writes them: surcharge,
/// extraction, rate and the sensor's lag (coefficients of the demo's size).
fn rhex_corrected_config() -> terzaghi::config::NodeConfig {
    let mut extra = String::new();
    for leg in RHEX_LEGS {
        extra += &format!(
            "-p {leg}.corrections.effects:=[surcharge,extraction,rate,sensor_lag] \
             -p {leg}.corrections.surcharge.normal_n_m4:=22500.0 -p {leg}.corrections.surcharge.tangential_n_m4:=500.0 \
             -p {leg}.corrections.extraction.drag_scale:=-0.8 -p {leg}.corrections.extraction.lift_scale:=-1.2 -p {leg}.corrections.extraction.slope_per_rad:=-40.0 \
             -p {leg}.corrections.rate.normal_kg_m3:=10.0 -p {leg}.corrections.rate.tangential_kg_m3:=1.0 -p {leg}.corrections.rate.ln_a_per_speed_excess:=0.05 -p {leg}.corrections.rate.scale_per_speed_excess:=0.1 -p {leg}.corrections.rate.speed_exponent:=1.0 \
             -p {leg}.corrections.typical_speed_rad_s:=4.0 -p {leg}.corrections.sensor_lag.time_constant_s:=0.01 "
        );
    }
    rhex_config_with(&extra)
}

fn rhex_config_with(ros_args: &str) -> terzaghi::config::NodeConfig {
    use terzaghi::config::{NodeConfig, defaults, parse_params_yaml, parse_value};
    let mut p = defaults();
    let words: Vec<&str> = ros_args.split_whitespace().collect();
    let overrides: Vec<(String, terzaghi::config::ParamValue)> = words
        .chunks(2)
        .filter_map(|w| {
            let (k, v) = w.get(1)?.split_once(":=")?;
            Some((k.to_string(), parse_value(v)))
        })
        .collect();
    p.extend(
        parse_params_yaml(
            include_str!("../launch_configs/rhex.yaml"),
            "rhex",
            "terzaghi",
            "/",
        )
        .unwrap(),
    );
    p.extend(overrides);
    NodeConfig::from_params(&p, "terzaghi", "/", &[]).unwrap()
}

/// The node's work for one JointState of six legs, without DDS: what `node_processing`
/// contains besides the publishes.
fn node_core(c: &mut Criterion) {
    node_core_with(c, "node_core_joint_state_6_legs", rhex_config());
    node_core_with(
        c,
        "node_core_joint_state_6_legs_corrected",
        rhex_corrected_config(),
    );
    node_core_with_tf(c);
    // Six wheel legs (the real wheel of tests/data/real-wheel, 360 rim elements) in the plate
    // runs' medium, at the configured hip height; and the same with the bearing of sheared sand
    // the slip sweep fitted.
    for (name, medium) in [
        ("node_core_joint_state_6_wheel_legs", "medium_without_shape"),
        (
            "node_core_joint_state_6_wheel_legs_sheared",
            "medium_slip_sweep",
        ),
    ] {
        let mut wheels = String::from("-p model:=rft ");
        for leg in RHEX_LEGS {
            wheels += &format!(
                "-p {leg}.shape:=wheel -p {leg}.wheel.radius_m:=0.058 -p {leg}.length_m:=0.058 -p {leg}.width_m:=0.05 -p {leg}.hip_height_m:=0.033 -p {leg}.medium:={}/tests/data/{medium}.yaml ",
                env!("CARGO_MANIFEST_DIR")
            );
        }
        node_core_with(c, name, rhex_config_with(&wheels));
    }
}

/// The same with every hip placed by the robot's state: each leg's `hip_frame` under
/// `base_link` (`/tf_static`), and the body's pose on `/tf` with every JointState, as a robot's
/// state publisher sends it; the work of both messages.
fn node_core_with_tf(c: &mut Criterion) {
    use terzaghi::msgs::{
        Header, JointState, Quaternion, TfMessage, Time, Transform, TransformStamped, Vector3,
    };
    use terzaghi::node::{Input, NodeCore, Outputs};
    let legs = RHEX_LEGS;
    let args: String = legs
        .iter()
        .map(|l| format!("-p {l}.hip_frame:={l}_hip "))
        .collect();
    let cfg = rhex_config_with(&args);
    let names: Vec<String> = cfg.legs.iter().map(|l| l.joint.clone()).collect();
    let tf = |parent: &str, child: &str, t_ns: i64, z: f64, pitch: f64| TransformStamped {
        header: Header {
            stamp: Time::from_nanos(t_ns).unwrap(),
            frame_id: parent.into(),
        },
        child_frame_id: child.into(),
        transform: Transform {
            translation: Vector3 { x: 0.0, y: 0.0, z },
            rotation: Quaternion {
                x: 0.0,
                y: (pitch / 2.0).sin(),
                z: 0.0,
                w: (pitch / 2.0).cos(),
            },
        },
    };
    let mut core = NodeCore::new(cfg);
    let mut out = Outputs::default();
    core.handle(
        Input::Tf(
            &TfMessage {
                transforms: legs
                    .iter()
                    .map(|l| tf("base_link", &format!("{l}_hip"), 0, 0.0, 0.0))
                    .collect(),
            },
            true,
        ),
        &mut out,
    );
    let mut k = 0i64;
    c.bench_function("node_core_joint_state_6_legs_tf", |b| {
        b.iter(|| {
            k += 1;
            let t_ns = k * 1_000_000;
            let phase = k as f64 * 0.004;
            let state = TfMessage {
                transforms: vec![tf(
                    "odom",
                    "base_link",
                    t_ns,
                    0.06 + 0.01 * (2.0 * phase).sin(),
                    0.05 * (2.0 * phase).cos(),
                )],
            };
            core.handle(Input::Tf(black_box(&state), false), &mut out);
            let beta = phase % std::f64::consts::TAU;
            let msg = JointState {
                header: Header {
                    stamp: Time::from_nanos(t_ns).unwrap(),
                    frame_id: String::new(),
                },
                name: names.clone(),
                position: vec![beta, beta, beta, -beta, -beta, -beta],
                velocity: vec![],
                effort: vec![],
            };
            out.clear();
            core.handle(Input::Joints(black_box(&msg)), &mut out);
            out.legs.len()
        })
    });
}

fn node_core_with(c: &mut Criterion, name: &str, cfg: terzaghi::config::NodeConfig) {
    use terzaghi::msgs::{Header, JointState, Time};
    use terzaghi::node::{Input, NodeCore, Outputs};
    let names: Vec<String> = cfg.legs.iter().map(|l| l.joint.clone()).collect();
    let mut core = NodeCore::new(cfg);
    let mut out = Outputs::default();
    let mut k = 0i64;
    c.bench_function(name, |b| {
        b.iter(|| {
            k += 1;
            let beta = (k as f64 * 0.004) % std::f64::consts::TAU;
            let msg = JointState {
                header: Header {
                    stamp: Time::from_nanos(k * 1_000_000).unwrap(),
                    frame_id: String::new(),
                },
                name: names.clone(),
                position: vec![beta, beta, beta, -beta, -beta, -beta],
                velocity: vec![],
                effort: vec![],
            };
            out.clear();
            core.handle(Input::Joints(black_box(&msg)), &mut out);
            out.legs.len()
        })
    });
}

/// What the live view (`--foxglove`) adds to the node's work for one JointState of six legs when
/// no client is connected: the JointState and each leg's predicted wrench and leg force offered
/// to a server on loopback with no client.
fn live_view_without_client(c: &mut Criterion) {
    use terzaghi::msgs::{JointState, LegForce, WrenchStamped};
    use terzaghi::node::handle::Topics;
    use terzaghi::node::live::Live;
    let cfg = rhex_config();
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let live = rt
        .block_on(Live::start(
            "127.0.0.1:0".parse().unwrap(),
            "bench",
            &Topics::new(&cfg),
        ))
        .unwrap();
    let js = JointState {
        name: cfg.legs.iter().map(|l| l.joint.clone()).collect(),
        position: vec![0.5; 6],
        ..Default::default()
    };
    let wrench = WrenchStamped::default();
    let force = LegForce::default();
    c.bench_function("live_view_no_client_joint_state_6_legs", |b| {
        b.iter(|| {
            live.joints.log(black_box(&js));
            for leg in 0..6 {
                live.wrench[leg].log(black_box(&wrench));
                live.force[leg].log(black_box(&force));
            }
        })
    });
    // The server stops inside its runtime.
    rt.block_on(async move { drop(live) });
}

criterion_group!(node, node_core, live_view_without_client);
