//! Criterion benchmarks of the hand-written readers and writers of a session against the
//! crates they stand beside, on the same input in one run: `cargo bench --bench session`.
//!
//! - `cdr_decode`: a six-joint JointState, decoded into a reused message
//!   ([`terzaghi::msgs::DecodeInto`]) and by serde (`cdr_encoding`, [`terzaghi::msgs::from_cdr`]).
//! - `chunk_messages`: the message records of a decompressed chunk of 1,000 JointStates, read by
//!   [`terzaghi::record::read::message_records`] and by mcap's `LinearReader`.
//! - `csv_rows`: 4,096 rows of a re-evaluation, written by
//!   [`terzaghi::session::csv_rows::CsvRows`] and by the csv crate (the same float text, zmij).

use criterion::{Criterion, black_box, criterion_group, criterion_main};
use terzaghi::model::Regime;
use terzaghi::msgs::{DecodeInto, Header, JointState, Time, from_cdr, to_cdr};
use terzaghi::session::csv_rows::CsvRows;
use terzaghi::session::reevaluate::Row;

fn joint_state(k: u32) -> JointState {
    JointState {
        header: Header {
            stamp: Time {
                sec: 1_700_000_000,
                nanosec: k * 1_000_000 % 1_000_000_000,
            },
            frame_id: "base_link".into(),
        },
        name: [
            "front_left",
            "middle_left",
            "rear_left",
            "front_right",
            "middle_right",
            "rear_right",
        ]
        .iter()
        .map(|s| format!("{s}_hip"))
        .collect(),
        position: (0..6).map(|i| 0.001 * k as f64 + i as f64).collect(),
        velocity: vec![4.0; 6],
        effort: vec![],
    }
}

fn cdr_decode(c: &mut Criterion) {
    let bytes = to_cdr(&joint_state(7)).unwrap();
    let mut g = c.benchmark_group("cdr_decode");
    let mut held = JointState::default();
    g.bench_function("decode_into", |b| {
        b.iter(|| {
            held.decode_into(black_box(&bytes)).unwrap();
            held.position[0]
        })
    });
    g.bench_function("cdr_encoding", |b| {
        b.iter(|| from_cdr::<JointState>(black_box(&bytes)).unwrap().position[0])
    });
    g.finish();
}

/// The records of a chunk: a schema, a channel, then `n` message records, as the recorder
/// writes them.
fn chunk_records(n: u32) -> Vec<u8> {
    let mut out = Vec::new();
    let mut record = |op: u8, body: &[u8]| {
        out.push(op);
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(body);
    };
    let mut schema = Vec::new();
    schema.extend_from_slice(&1u16.to_le_bytes());
    for s in ["sensor_msgs/msg/JointState", "ros2msg", "# definition"] {
        schema.extend_from_slice(&(s.len() as u32).to_le_bytes());
        schema.extend_from_slice(s.as_bytes());
    }
    record(0x03, &schema);
    let mut channel = Vec::new();
    channel.extend_from_slice(&1u16.to_le_bytes());
    channel.extend_from_slice(&1u16.to_le_bytes());
    for s in ["/joint_states", "cdr"] {
        channel.extend_from_slice(&(s.len() as u32).to_le_bytes());
        channel.extend_from_slice(s.as_bytes());
    }
    channel.extend_from_slice(&0u32.to_le_bytes());
    record(0x04, &channel);
    for k in 0..n {
        let data = to_cdr(&joint_state(k)).unwrap();
        let mut m = Vec::new();
        m.extend_from_slice(&1u16.to_le_bytes());
        m.extend_from_slice(&k.to_le_bytes());
        m.extend_from_slice(&(u64::from(k) * 1_000_000).to_le_bytes());
        m.extend_from_slice(&(u64::from(k) * 1_000_000).to_le_bytes());
        m.extend_from_slice(&data);
        record(0x05, &m);
    }
    out
}

fn chunk_messages(c: &mut Criterion) {
    let records = chunk_records(1000);
    let mut g = c.benchmark_group("chunk_messages");
    g.bench_function("message_records", |b| {
        b.iter(|| {
            let mut bytes = 0usize;
            terzaghi::record::read::message_records(black_box(&records), |_, _, _, d| {
                bytes += d.len()
            })
            .unwrap();
            bytes
        })
    });
    g.bench_function("mcap_linear_reader", |b| {
        b.iter(|| {
            let mut bytes = 0usize;
            for r in mcap::read::LinearReader::sans_magic(black_box(&records)) {
                if let mcap::records::Record::Message { data, .. } = r.unwrap() {
                    bytes += data.len();
                }
            }
            bytes
        })
    });
    g.finish();
}

fn rows(n: usize) -> Vec<Row> {
    (0..n)
        .map(|i| {
            let t = 1_700_000_000.0 + (i / 6) as f64 * 1e-3;
            let beta = 0.5 + (i / 6 % 1000) as f64 * 2e-3;
            let inside = i % 3 != 0;
            let (drag, lift) = if inside {
                (10.5 + beta, 4.5 + beta)
            } else {
                (0.0, 0.0)
            };
            Row {
                t_s: t,
                leg: i % 6,
                beta_rad: beta,
                regime: if inside {
                    Regime::Penetration
                } else {
                    Regime::OutOfMedium
                },
                measured_drag_n: Some(if inside { 10.0 + beta.sin() } else { 0.0 }),
                measured_lift_n: Some(if inside { 5.0 + beta.cos() } else { 0.0 }),
                predicted_drag_n: drag,
                predicted_lift_n: lift,
                predicted_hip_torque_nm: if inside { 1.5 * beta } else { 0.0 },
                b_k: 30.0,
                a: 2.2,
                identified: i > n / 2,
                bare_drag_n: drag,
                bare_lift_n: lift,
                expected_reading_drag_n: drag,
                expected_reading_lift_n: lift,
                predicted_side_n: 0.0,
                predicted_roll_moment_nm: 0.0,
                predicted_yaw_moment_nm: 0.0,
            }
        })
        .collect()
}

/// The same rows through the csv crate, field by field, with the same float text.
fn csv_crate(rows: &[Row], legs: &[String], out: &mut Vec<u8>) {
    let mut w = csv::Writer::from_writer(out);
    let mut f = zmij::Buffer::new();
    let mut float = |w: &mut csv::Writer<&mut Vec<u8>>, v: Option<f64>| match v {
        Some(v) => w.write_field(f.format(v)).unwrap(),
        None => w.write_field("").unwrap(),
    };
    for r in rows {
        float(&mut w, Some(r.t_s));
        w.write_field(&legs[r.leg]).unwrap();
        float(&mut w, Some(r.beta_rad));
        w.write_field(r.regime.as_str()).unwrap();
        float(&mut w, r.measured_drag_n);
        float(&mut w, r.measured_lift_n);
        for v in [
            r.predicted_drag_n,
            r.predicted_lift_n,
            r.predicted_hip_torque_nm,
            r.b_k,
            r.a,
        ] {
            float(&mut w, Some(v));
        }
        w.write_field(if r.identified { "true" } else { "false" })
            .unwrap();
        for v in [
            r.bare_drag_n,
            r.bare_lift_n,
            r.expected_reading_drag_n,
            r.expected_reading_lift_n,
            r.predicted_side_n,
            r.predicted_roll_moment_nm,
            r.predicted_yaw_moment_nm,
        ] {
            float(&mut w, Some(v));
        }
        w.write_record(None::<&[u8]>).unwrap();
    }
    w.flush().unwrap();
}

fn csv_rows(c: &mut Criterion) {
    let rows = rows(4096);
    let legs: Vec<String> = (0..6).map(|i| format!("leg_{i}")).collect();
    let mut g = c.benchmark_group("csv_rows");
    let mut text = Vec::with_capacity(1 << 20);
    let mut writer = CsvRows::new(&legs).unwrap();
    // The two write the same text: the comparison is of one output.
    let (mut ours, mut crate_text) = (Vec::new(), Vec::new());
    for r in &rows {
        writer.push(&mut ours, r);
    }
    csv_crate(&rows, &legs, &mut crate_text);
    assert!(ours == crate_text, "CsvRows and the csv crate disagree");
    g.bench_function("csv_rows", |b| {
        b.iter(|| {
            text.clear();
            for r in &rows {
                writer.push(&mut text, black_box(r));
            }
            text.len()
        })
    });
    g.bench_function("csv_crate", |b| {
        b.iter(|| {
            text.clear();
            csv_crate(black_box(&rows), &legs, &mut text);
            text.len()
        })
    });
    g.finish();
}

criterion_group!(benches, cdr_decode, chunk_messages, csv_rows);
criterion_main!(benches);
