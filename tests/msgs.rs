//! Every message struct's CDR bytes decode, with the `.msg` definition the project ships, through
//! an independent decoder (Python mcap-ros2-support), to the values that were encoded.

mod common;

use common::*;
use serde::Serialize;
use std::io::Write;
use std::process::Stdio;
use terzaghi::msgs::*;

fn item<M: RosMessage + Serialize>(m: &M) -> (serde_json::Value, serde_json::Value) {
    let cdr = to_cdr(m).unwrap();
    let hex: String = cdr.iter().map(|b| format!("{b:02x}")).collect();
    (
        serde_json::json!({"schema_name": M::type_name(), "schema_text": M::schema_text(), "cdr_hex": hex}),
        serde_json::to_value(m).unwrap(),
    )
}

#[test]
fn every_message_decodes_with_its_definition_in_mcap_ros2() {
    let header = Header {
        stamp: Time {
            sec: 1_700_000_123,
            nanosec: 456_789,
        },
        frame_id: "front_left_hip".into(),
    };
    let items = vec![
        item(&Time {
            sec: -5,
            nanosec: 7,
        }),
        item(&header),
        item(&JointState {
            header: header.clone(),
            name: vec!["a".into(), "bé".into()],
            position: vec![0.5, -1.25],
            velocity: vec![],
            effort: vec![3.0],
        }),
        item(&Vector3 {
            x: 1.5,
            y: -2.0,
            z: 1e-300,
        }),
        item(&Wrench {
            force: Vector3 {
                x: 1.0,
                y: 2.0,
                z: 3.0,
            },
            torque: Vector3 {
                x: 4.0,
                y: 5.0,
                z: 6.0,
            },
        }),
        item(&WrenchStamped {
            header: header.clone(),
            wrench: Wrench {
                force: Vector3 {
                    x: -39.5,
                    y: 0.0,
                    z: 45.25,
                },
                torque: Vector3 {
                    x: 0.0,
                    y: 12.5,
                    z: 0.0,
                },
            },
        }),
        item(&KeyValue {
            key: "b_k".into(),
            value: "2.0".into(),
        }),
        item(&DiagnosticStatus {
            level: DiagnosticStatus::WARN,
            name: "leg".into(),
            message: "m".into(),
            hardware_id: "hip".into(),
            values: vec![KeyValue {
                key: "k".into(),
                value: "v".into(),
            }],
        }),
        item(&DiagnosticArray {
            header: header.clone(),
            status: vec![
                DiagnosticStatus {
                    level: 0,
                    name: "n".into(),
                    message: String::new(),
                    hardware_id: String::new(),
                    values: vec![]
                };
                2
            ],
        }),
        item(&LegForce {
            header: header.clone(),
            attack_angle_rad: 1.0471975511965976,
            submerged_length_m: 0.0768,
            depth_m: 0.0665,
            drag_n: 39.674130,
            lift_n: 45.639865,
            hip_torque_nm: 12.831005,
            regime: 1,
            model: "improved".into(),
            b_k: 2.0,
            a: 1.5,
            delta_deg: 19.0,
            identified: true,
            bare_drag_n: 35.0,
            bare_lift_n: 40.0,
            correction_names: vec!["surcharge".into(), "extraction".into()],
            correction_drag_n: vec![4.674130, 0.0],
            correction_lift_n: vec![5.639865, 0.0],
            sensor_drag_n: 40.0,
            sensor_lift_n: 45.0,
            hip_height_m: 0.1375,
            body_pitch_rad: -0.0625,
            hip_forward_m_s: 0.25,
            hip_up_m_s: -0.03125,
            robot_state: true,
            rft_scale: 0.875,
            side_n: -2.5,
            roll_moment_nm: 0.1875,
            yaw_moment_nm: -0.3125,
            hip_lateral_m_s: 0.0625,
        }),
        item(&PoseStamped {
            header: header.clone(),
            pose: Pose {
                position: Point {
                    x: 0.5,
                    y: -0.125,
                    z: 0.2,
                },
                orientation: Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.6,
                    w: 0.8,
                },
            },
        }),
        item(&TfMessage {
            transforms: vec![
                TransformStamped {
                    header: Header {
                        stamp: header.stamp,
                        frame_id: "odom".into(),
                    },
                    child_frame_id: "base_link".into(),
                    transform: Transform {
                        translation: Vector3 {
                            x: 1.5,
                            y: -0.25,
                            z: 0.125,
                        },
                        rotation: Quaternion {
                            x: 0.0,
                            y: 0.6,
                            z: 0.0,
                            w: 0.8,
                        },
                    },
                },
                TransformStamped::default(),
            ],
        }),
        item(&ModelParams {
            header,
            b_k: 2.0,
            a: 1.5,
            delta_deg: 19.0,
            std_b_k: 0.01,
            std_a: 0.005,
            std_delta_deg: 0.0,
            samples_used: u64::MAX - 1,
            samples_rejected: 3,
            innovation_rms_n: 1.2,
            converged: true,
            changes_detected: 4_000_000_000,
            correction_params: vec!["cohesion.normal_pa".into(), "cohesion.tangential_pa".into()],
            correction_values: vec![6466.3, -1142.2],
            correction_stds: vec![17.7, 10.1],
            rft_scale: 1.3271,
            std_rft_scale: 0.0125,
            surface_offset_m: -0.0075,
            std_surface_offset_m: 0.0005,
            surface_converged: true,
        }),
    ];
    let (input, want): (Vec<_>, Vec<_>) = items.into_iter().unzip();
    let mut child = std::process::Command::new(python())
        .arg(repo().join("tests/python/decode_cdr.py"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(serde_json::to_string(&input).unwrap().as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    let got: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g, w, "decoded by mcap-ros2-support vs encoded");
    }
}
