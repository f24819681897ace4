//! Criterion benchmarks of one model evaluation: `cargo bench --bench model`.

use criterion::{Criterion, black_box, criterion_group, criterion_main};
use terzaghi::model::{
    FittingWidth, Medium, Plate, RftCoefficients, RftFit, RftModel, TerzaghiModel,
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
}

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

criterion_group!(benches, models, online_update);
criterion_main!(benches, node);

/// The node's configuration for the six-legged robot of `launch_configs/rhex.yaml`.
fn rhex_config() -> terzaghi::config::NodeConfig {
    use terzaghi::config::{NodeConfig, defaults, parse_params_yaml};
    let mut p = defaults();
    p.extend(
        parse_params_yaml(
            include_str!("../launch_configs/rhex.yaml"),
            "rhex",
            "terzaghi",
            "/",
        )
        .unwrap(),
    );
    NodeConfig::from_params(&p, "terzaghi", "/", &[]).unwrap()
}

/// The node's work for one JointState of six legs, without DDS: what `node_processing`
/// contains besides the publishes.
fn node_core(c: &mut Criterion) {
    use terzaghi::msgs::{Header, JointState, Time};
    use terzaghi::node::NodeCore;
    let cfg = rhex_config();
    let names: Vec<String> = cfg.legs.iter().map(|l| l.joint.clone()).collect();
    let mut core = NodeCore::new(cfg);
    let mut out = Vec::new();
    let mut k = 0i64;
    c.bench_function("node_core_joint_state_6_legs", |b| {
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
            core.on_joint_state(black_box(&msg), &mut out);
            out.len()
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
