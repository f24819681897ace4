//! Node parameters as a ROS user gives them: a params YAML file (`/**:` or the node's name, then
//! `ros__parameters:`, nested keys flattened with dots) and `--ros-args` (`-p name:=value`,
//! `--params-file FILE`, `-r __node:=NAME`, `-r __ns:=/NS`, `-r from:=to`). Parsed and validated
//! here, once, into a [`NodeConfig`]; every error names the parameter and its value.
//!
//! - `params`: parameter values as ROS 2 types them.
//! - `ros_args`: the `--ros-args` command line.
//! - `yaml`: params files, and the parameters of one node from defaults, files and `-p`.
//! - `node`: the node's configuration ([`NodeConfig`]), validated from parameters.
//! - `names`: ROS names: topic resolution and remapping, and the node's output topics.
//! - `env`: the ROS 2 environment variables the node honours.

pub(crate) mod corrections;
mod env;
mod names;
mod node;
mod params;
mod ros_args;
mod yaml;

pub use env::*;
pub use names::*;
pub use node::*;
pub use params::*;
pub use ros_args::*;
pub use yaml::*;

use crate::model::ModelError;

/// What is wrong with the parameters or the command line; names the culprit.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("parameter {name} = {value}: {reason}")]
    /// A parameter whose value is refused.
    Invalid {
        /// The parameter's name.
        name: String,
        /// Its value, as given.
        value: String,
        /// Why it is refused.
        reason: String,
    },
    #[error("parameter {name} is required: {hint}")]
    /// A parameter that must be given and was not.
    Missing {
        /// The parameter's name.
        name: String,
        /// What to give.
        hint: String,
    },
    #[error("parameter {name}: {error}")]
    /// A parameter the model refuses.
    Model {
        /// The parameter's name.
        name: String,
        /// The model's refusal.
        error: ModelError,
    },
    #[error("cannot read params file {path}: {error}")]
    /// A params file that cannot be read.
    ReadFile {
        /// The file.
        path: String,
        /// The system's error.
        error: std::io::Error,
    },
    #[error("params file {path}: {reason}")]
    /// A params file that is not a ROS 2 params file.
    BadFile {
        /// The file.
        path: String,
        /// What is wrong with it.
        reason: String,
    },
    #[error("--ros-args: {0}")]
    /// `--ros-args` that do not parse (what is wrong).
    RosArgs(String),
    #[error("{name}={value}: {reason}")]
    /// An environment variable the node reads, with a value it refuses.
    Env {
        /// The variable.
        name: &'static str,
        /// Its value.
        value: String,
        /// Why it is refused.
        reason: &'static str,
    },
}

fn invalid(name: &str, value: &impl std::fmt::Display, reason: impl Into<String>) -> ConfigError {
    ConfigError::Invalid {
        name: name.to_string(),
        value: value.to_string(),
        reason: reason.into(),
    }
}

fn model_err(name: &str) -> impl Fn(ModelError) -> ConfigError + '_ {
    move |error| ConfigError::Model {
        name: name.to_string(),
        error,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    const YAML: &str = "
/**:
  ros__parameters:
    model: improved
    legs: [left, right]
    left:
      length_m: 0.25
      width_m: 0.06
      hip_height_m: 0.15
      medium: hit_sand
      ft_topic: left/ft
    right:
      length_m: 0.25
      width_m: 0.04
      hip_height_m: 0.15
      unit_weight_n_m3: 16170
      phi_deg: 32.0
      delta_deg: 19.0
      b_k: 4.45
      a: 1.61
      direction: -1
    estimator:
      fit_delta: true
other_node:
  ros__parameters:
    model: rft
";

    fn load(extra: &str) -> Result<NodeConfig, ConfigError> {
        let mut p = defaults();
        p.extend(parse_params_yaml(YAML, "t.yaml", "terzaghi", "/").unwrap());
        let (_, ros) = parse_ros_args(&args(&format!("--ros-args {extra}")))?;
        for (k, v) in ros.params {
            p.insert(k, v);
        }
        NodeConfig::from_params(
            &p,
            ros.node_name.as_deref().unwrap_or("terzaghi"),
            ros.namespace.as_deref().unwrap_or("/"),
            &ros.remaps,
        )
    }

    /// A misspelled key is refused at every level, naming the key and the nearest known one;
    /// ROS's own use_sim_time and every default are known.
    #[test]
    fn misspelled_keys_are_refused_with_the_nearest_name() {
        let refused = |extra: &str| load(extra).unwrap_err().to_string();
        let e = refused("-p use_identifed:=false");
        assert!(
            e.contains("use_identifed") && e.contains("did you mean use_identified?"),
            "{e}"
        );
        let e = refused("-p estimator.memory_strokez:=4.0");
        assert!(
            e.contains("estimator.memory_strokez")
                && e.contains("did you mean estimator.memory_strokes?"),
            "{e}"
        );
        let e = refused("-p left.lenght_m:=0.2");
        assert!(
            e.contains("left.lenght_m") && e.contains("did you mean length_m?"),
            "{e}"
        );
        let e = refused("-p lefft.length_m:=0.2");
        assert!(
            e.contains("did you mean left.length_m?") && e.contains("not a leg"),
            "{e}"
        );
        let e = refused("-p frobnicate:=1");
        assert!(
            e.contains("unknown parameter") && !e.contains("did you mean"),
            "{e}"
        );
        load("-p use_sim_time:=true -p estimator.memory_strokes:=4.0").unwrap();
    }

    #[test]
    fn params_file_and_overrides() {
        let c = load("-p left.b_k:=3 -p left.a:=1.2 -r __ns:=/robot -r left/ft:=/sensors/left")
            .unwrap();
        assert_eq!(c.legs.len(), 2);
        assert_eq!(c.namespace, "/robot");
        assert_eq!(c.joint_states_topic, "/robot/joint_states");
        assert_eq!(c.legs[0].ft_topic.as_deref(), Some("/sensors/left"));
        assert_eq!((c.legs[0].width.b_k(), c.legs[0].width.a()), (3.0, 1.2));
        assert_eq!(c.legs[1].direction, -1.0);
        assert_eq!(c.legs[1].joint, "right");
        assert!(c.estimator.fit_delta);
        // The preset's Table 1 fit for a 60 mm plate when no b_k is given.
        let c = load("").unwrap();
        assert_eq!(c.legs[0].width.b_k(), 22.40);
        // Corrections set as parameters, as a corrected.yaml or `param set` gives them.
        let c = load(
            "-p left.corrections.effects:=[sensor_bias] -p left.corrections.sensor_bias.drag_n:=1.5 -p left.corrections.sensor_bias.lift_n:=-0.5",
        )
        .unwrap();
        let k = c.legs[0].corrections.as_ref().unwrap();
        assert_eq!(k.terms[0].coefficients, vec![1.5, -0.5]);
        assert!(c.legs[1].corrections.is_none());
    }

    #[test]
    fn a_wheel_leg_is_a_body_predicted_by_rft_over_its_surface() {
        let c = load(
            "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=wheel -p left.wheel.radius_m:=0.05 -p left.length_m:=0.05 -p left.hip_height_m:=0.03 -p left.wheel.grouser_count:=12 -p left.wheel.grouser_height_m:=0.005 -p left.wheel.grouser_thickness_m:=0.003",
        )
        .unwrap();
        let body = c.legs[0].body.as_ref().unwrap();
        // Its reach is the rim's radius and the grousers' height (to a grouser tip's corner).
        assert!((body.reach_m() - 0.055).abs() < 1e-4, "{}", body.reach_m());
        assert!(c.legs[1].body.is_none());
        let m = c.leg_model(0, c.legs[0].width, None).unwrap();
        let crate::model::ForceModel::Body(b) = &m else {
            panic!("{m:?}")
        };
        // Held 25 mm deep, the sand bears it.
        let p = b
            .predict(0.0, &crate::model::HipMotion::still(0.03))
            .unwrap();
        assert!(p.lift_n > 0.0 && p.drag_n == 0.0, "{p:?}");
    }

    #[test]
    fn a_foot_or_a_mesh_leg_is_a_body_at_its_place_below_the_hip() {
        // A leg given by its body alone: no length_m or width_m.
        let foot = |extra: &str| {
            let mut p = defaults();
            let yaml = "/**:\n  ros__parameters:\n    model: rft\n    legs: [left]\n    left:\n      hip_height_m: 0.11\n      medium: poppy_lp\n      rft_coeffs: poppy_lp\n";
            p.extend(parse_params_yaml(yaml, "t.yaml", "terzaghi", "/").unwrap());
            let (_, ros) = parse_ros_args(&args(&format!("--ros-args {extra}"))).unwrap();
            p.extend(ros.params);
            (NodeConfig::from_params(&p, "terzaghi", "/", &[]), p)
        };
        // A sphere foot 20 mm in radius at the end of a 0.1 m leg: its reach is 0.12 m, its
        // width its diameter.
        let (c, given) = foot(
            "-p left.shape:=sphere -p left.foot.radius_m:=0.02 -p left.body.xyz_m:=[0.0,0.0,-0.1]",
        );
        let c = c.unwrap();
        let leg = &c.legs[0];
        assert!(
            (leg.plate.length_m() - 0.12).abs() < 1e-9,
            "{:?}",
            leg.plate
        );
        assert!((leg.plate.width_m() - 0.04).abs() < 1e-3, "{:?}", leg.plate);
        let m = c.leg_model(0, leg.width, None).unwrap();
        let crate::model::ForceModel::Body(b) = &m else {
            panic!("{m:?}")
        };
        // Held 10 mm deep, the sand bears it; dragged forward, it is pushed back.
        let held = b
            .predict(0.0, &crate::model::HipMotion::still(0.11))
            .unwrap();
        assert!(held.lift_n > 0.0 && held.drag_n == 0.0, "{held:?}");
        let dragged = b
            .predict(
                0.0,
                &crate::model::HipMotion {
                    height_m: 0.11,
                    forward_m_s: 0.05,
                    ..Default::default()
                },
            )
            .unwrap();
        assert!(dragged.drag_n < 0.0 && dragged.lift_n > 0.0, "{dragged:?}");
        // Its values in force (length_m and width_m among them) read back as the same leg.
        let again = NodeConfig::from_params(&c.effective_params(&given), "terzaghi", "/", &[]);
        assert_eq!(again.unwrap().legs[0].plate, leg.plate);
        // A box, a disc, and a box drawn as STL in millimetres and turned a quarter about z.
        let dir = tempfile::tempdir().unwrap();
        let stl = dir.path().join("foot.stl");
        let mut text = String::from("solid foot\n");
        for t in crate::model::box_triangles([40.0, 20.0, 10.0], [0.0; 3]) {
            text += " facet normal 0 0 0\n  outer loop\n";
            for v in t {
                text += &format!("   vertex {} {} {}\n", v[0], v[1], v[2]);
            }
            text += "  endloop\n endfacet\n";
        }
        std::fs::write(&stl, text + "endsolid foot\n").unwrap();
        let mesh = format!(
            "-p left.shape:=mesh -p left.mesh.file:={} -p left.mesh.scale:=0.001 -p left.body.xyz_m:=[0.0,0.0,-0.1] -p left.body.rpy_rad:=[0.0,0.0,1.5707963267948966]",
            stl.display()
        );
        for (extra, reach, width) in [
            (
                "-p left.shape:=box -p left.foot.size_m:=[0.04,0.02,0.01] -p left.body.xyz_m:=[0.0,0.0,-0.1]",
                0.105,
                0.02,
            ),
            (
                "-p left.shape:=disc -p left.foot.radius_m:=0.03 -p left.foot.thickness_m:=0.01 -p left.body.xyz_m:=[0.0,0.0,-0.1]",
                0.105,
                0.06,
            ),
            (mesh.as_str(), 0.105, 0.04),
        ] {
            let c = foot(extra).0.unwrap();
            let p = &c.legs[0].plate;
            assert!((p.length_m() - reach).abs() < 1e-6, "{extra}: {p:?}");
            assert!((p.width_m() - width).abs() < 1e-3, "{extra}: {p:?}");
        }
    }

    #[test]
    fn a_leg_of_another_shape_is_predicted_by_rft_over_its_profile() {
        let c = load(
            "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=c_leg -p left.length_m:=0.1 -p left.hip_height_m:=0.04",
        )
        .unwrap();
        let p = c.legs[0].profile.as_ref().unwrap();
        assert_eq!(p.shape, "c_leg");
        // A half circle on the 100 mm chord, by default.
        let last = p.line.last().unwrap();
        assert!(
            (last.0 - 0.1).abs() < 1e-9 && last.1.abs() < 1e-9,
            "{last:?}"
        );
        let m = c.leg_model(0, c.legs[0].width, None).unwrap();
        let crate::model::ForceModel::Rft(r) = &m else {
            panic!("{m:?}")
        };
        assert!(r.profile().is_some());
        assert!(c.legs[1].profile.is_none());
        let c = load(
            "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=polyline -p left.profile:=[0.0,0.0,0.1,0.02,0.2,0.0]",
        )
        .unwrap();
        assert_eq!(c.legs[0].profile.as_ref().unwrap().line.len(), 3);
    }

    #[test]
    fn the_improved_model_without_b_k_and_a_from_anywhere_is_refused() {
        let leg = |extra: &str| {
            let yaml = format!(
                "/**:\n  ros__parameters:\n    legs: [fl]\n    fl:\n      length_m: 0.25\n      hip_height_m: 0.15\n{extra}"
            );
            let mut p = defaults();
            p.extend(parse_params_yaml(&yaml, "t", "terzaghi", "/").unwrap());
            NodeConfig::from_params(&p, "terzaghi", "/", &[]).map(|c| c.legs[0].width)
        };
        let custom = "      unit_weight_n_m3: 16170\n      phi_deg: 32.0\n      delta_deg: 19.0\n";
        // No preset, no b_k and a, no F/T to identify them: refused, as terzaghi predict does.
        let e = leg(&format!("      width_m: 0.06\n{custom}"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("fl.b_k is required"), "{e}");
        // A preset without a fit for this width: refused, naming the widths it has.
        let e = leg("      width_m: 0.07\n      medium: hit_sand\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("only for plate widths") && e.contains("0.06"),
            "{e}"
        );
        // Given, from the preset's fit, or learnt online from F/T (starting conventional).
        let w = leg(&format!(
            "      width_m: 0.06\n{custom}      b_k: 2.0\n      a: 1.5\n"
        ))
        .unwrap();
        assert_eq!((w.b_k(), w.a()), (2.0, 1.5));
        let w = leg("      width_m: 0.06\n      medium: hit_sand\n").unwrap();
        assert_eq!((w.b_k(), w.a()), (22.4, 7.78));
        let w = leg(&format!(
            "      width_m: 0.06\n{custom}      ft_topic: fl/ft\n"
        ))
        .unwrap();
        assert_eq!((w.b_k(), w.a()), (1.0, 1.0));
        // The conventional model needs neither.
        let yaml = format!(
            "/**:\n  ros__parameters:\n    model: conventional\n    legs: [fl]\n    fl:\n      length_m: 0.25\n      hip_height_m: 0.15\n      width_m: 0.06\n{custom}"
        );
        let mut p = defaults();
        p.extend(parse_params_yaml(&yaml, "t", "terzaghi", "/").unwrap());
        assert!(NodeConfig::from_params(&p, "terzaghi", "/", &[]).is_ok());
    }

    #[test]
    fn bad_values_name_parameter_and_value() {
        let cases = [
            ("-p left.width_m:=-1", "left.width_m"),
            ("-p left.width_m:=.nan", "left.width_m"),
            ("-p right.hip_height_m:=-0.1", "right.hip_height_m"),
            ("-p right.hip_height_m:=.inf", "right.hip_height_m"),
            ("-p right.length_m:=0", "right.length_m"),
            ("-p model:=fancy", "fancy"),
            ("-p right.direction:=2", "right.direction"),
            ("-p left.medium:=mud", "mud"),
            ("-p left.ft_frame:=base", "base"),
            ("-p left.lenght_m:=1", "left.lenght_m"),
            ("-p queue_depth:=0", "queue_depth"),
            ("-p estimator.forgetting_factor:=1.5", "forgetting"),
            ("-p right.phi_deg:=95", "95"),
            ("-p left.length_m:=abc", "abc"),
            ("-r __node:=9bad", "9bad"),
            // Corrections: of a leg the node does not have, unknown, out of bounds, or on a
            // model they are not terms of.
            (
                "-p rear.corrections.effects:=[surcharge]",
                "corrections for a leg \"rear\"",
            ),
            ("-p left.corrections.effects:=[moisture]", "moisture"),
            // Shapes: only RFT predicts a leg that is not a flat plate; an arc must span the
            // leg's length; a profile needs pairs of coordinates; a grid file must be read.
            ("-p left.shape:=c_leg", "set model to rft"),
            ("-p left.shape:=wheel", "wheel"),
            // A wheel needs its radius, all three grouser values or none, whole numbers where
            // it counts, and its reach as its length; a wheel's value on another shape is refused.
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=wheel",
                "left.wheel.radius_m",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=wheel -p left.wheel.radius_m:=-0.05",
                "left.wheel.radius_m",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=wheel -p left.wheel.radius_m:=0.05 -p left.wheel.grouser_count:=6",
                "left.wheel.grouser_count",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=wheel -p left.wheel.radius_m:=0.05 -p left.wheel.grouser_count:=2.5 -p left.wheel.grouser_height_m:=0.005 -p left.wheel.grouser_thickness_m:=0.003",
                "left.wheel.grouser_count",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=wheel -p left.wheel.radius_m:=0.05 -p left.wheel.grouser_count:=6 -p left.wheel.grouser_height_m:=0.005 -p left.wheel.grouser_thickness_m:=0.1",
                "left.wheel.grouser_thickness_m",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=wheel -p left.wheel.radius_m:=0.05 -p left.wheel.rim_elements:=10",
                "left.wheel.rim_elements",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=wheel -p left.wheel.radius_m:=0.05",
                "left.length_m",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.wheel.radius_m:=0.05",
                "left.wheel.radius_m",
            ),
            // A foot needs its sizes, RFT and a place below the hip; a foot's value on another
            // shape, a mesh that is not there, a width that is not its own are refused.
            (
                "-p left.shape:=sphere -p left.foot.radius_m:=0.02",
                "set model to rft",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=sphere",
                "left.foot.radius_m",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.foot.radius_m:=0.02",
                "left.foot.radius_m",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=sphere -p left.foot.radius_m:=0.02 -p left.body.xyz_m:=[0.0,0.0,0.1]",
                "left.body.xyz_m",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=box -p left.foot.size_m:=[0.04,0.02]",
                "left.foot.size_m",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=mesh -p left.mesh.file:=/nonexistent/foot.stl",
                "left.mesh.file",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=sphere -p left.foot.radius_m:=0.02 -p left.body.xyz_m:=[0.0,0.0,-0.1] -p left.length_m:=0.12 -p left.width_m:=0.06",
                "left.width_m",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=sphere -p left.foot.radius_m:=0.02 -p left.body.rpy_rad:=[0.0,0.0,1.0]",
                "left.body.rpy_rad",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=c_leg -p left.c_leg.radius_m:=0.5",
                "left.c_leg.radius_m",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=polyline -p left.profile:=[0.0,0.0,0.1]",
                "left.profile",
            ),
            // A polyline that crosses itself, and an arc of zero radius.
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=polyline -p left.profile:=[0.0,0.0,0.1,0.1,0.1,0.0,0.0,0.1]",
                "crosses itself",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.shape:=c_leg -p left.c_leg.radius_m:=0.0",
                "left.c_leg.radius_m",
            ),
            (
                "-p model:=rft -p right.rft_coeffs:=poppy_lp -p left.rft_grid_file:=/nonexistent/grid.csv",
                "/nonexistent/grid.csv",
            ),
            // A trough deeper than the leg is long, or negative.
            ("-p left.trough_depth_m:=0.3", "left.trough_depth_m"),
            ("-p left.trough_depth_m:=-0.01", "left.trough_depth_m"),
            // A heap higher than the leg is long, or no number.
            (
                "-p left.trough_exit_depth_m:=-0.3",
                "left.trough_exit_depth_m",
            ),
            (
                "-p left.trough_exit_depth_m:=nan",
                "left.trough_exit_depth_m",
            ),
            // A sensor's sample period that is negative, slower than 1 Hz, or no number.
            ("-p left.sensor_hold_s:=-0.01", "left.sensor_hold_s"),
            ("-p left.sensor_hold_s:=2.0", "left.sensor_hold_s"),
            ("-p left.sensor_hold_s:=nan", "left.sensor_hold_s"),
            // A speed law without RFT, one from no file, and one from the grid (not a speed table).
            (
                "-p left.rft_speed_file:=tests/dem/campaign/rft_entry.csv",
                "left.rft_speed_file",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.rft_speed_file:=/nonexistent/speed.csv",
                "/nonexistent/speed.csv",
            ),
            (
                "-p model:=rft -p left.rft_coeffs:=poppy_lp -p right.rft_coeffs:=poppy_lp -p left.rft_speed_file:=tests/dem/campaign/rft_grid.csv",
                "no RFT speed law",
            ),
            (
                "-p left.corrections.effects:=[sensor_bias] -p left.corrections.sensor_bias.drag_n:=1e6 -p left.corrections.sensor_bias.lift_n:=0.0",
                "left.corrections.sensor_bias.drag_n = 1000000",
            ),
            (
                "-p left.corrections.effects:=[sensor_bias]",
                "left.corrections.sensor_bias.drag_n is required",
            ),
            (
                "-p model:=conventional -p left.corrections.effects:=[sensor_bias] -p left.corrections.sensor_bias.drag_n:=1.0 -p left.corrections.sensor_bias.lift_n:=0.0",
                "terms of the improved model",
            ),
        ];
        for (extra, needle) in cases {
            let e = load(extra).unwrap_err().to_string();
            assert!(e.contains(needle), "{extra}: {e}");
        }
        let e = parse_ros_args(&args("--ros-args -p nonsense"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("name:=value"), "{e}");
        let e = parse_ros_args(&args("--ros-args --frobnicate"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("frobnicate"), "{e}");
    }

    #[test]
    fn ros_args_split_from_own_args() {
        let (own, ros) = parse_ros_args(&args(
            "--record x.mcap --ros-args -p a:=1 --params-file f.yaml -- --other",
        ))
        .unwrap();
        assert_eq!(own, args("--record x.mcap --other"));
        assert_eq!(ros.params, vec![("a".to_string(), ParamValue::Int(1))]);
        assert_eq!(ros.params_files, vec![PathBuf::from("f.yaml")]);
        assert_eq!(
            parse_value("[a, b]"),
            ParamValue::StringArray(vec!["a".into(), "b".into()])
        );
        assert_eq!(parse_value("0.5"), ParamValue::Double(0.5));
        assert_eq!(parse_value("hip"), ParamValue::String("hip".into()));
    }

    #[test]
    fn log_level_and_log_switches() {
        let (_, ros) = parse_ros_args(&args(
            "--ros-args --log-level terzaghi:=DEBUG --disable-stdout-logs",
        ))
        .unwrap();
        assert_eq!(ros.log_level, Some(LogLevel::Debug));
        assert!(ros.stdout_logs_disabled && !ros.rosout_logs_disabled);
        let (_, ros) = parse_ros_args(&args("--ros-args --log-level warn")).unwrap();
        assert_eq!(ros.log_level, Some(LogLevel::Warn));
        let e = parse_ros_args(&args("--ros-args --log-level loud"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("loud") && e.contains("debug"), "{e}");
    }

    #[test]
    fn node_sections_and_names() {
        let y = "terzaghi:\n  ros__parameters:\n    legs: [a]\n";
        assert!(
            parse_params_yaml(y, "f", "terzaghi", "/")
                .unwrap()
                .contains_key("legs")
        );
        let y2 = "/robot/terzaghi:\n  ros__parameters:\n    legs: [a]\n";
        assert!(parse_params_yaml(y2, "f", "terzaghi", "/robot").is_ok());
        let e =
            parse_params_yaml("other:\n  ros__parameters: {}\n", "f", "terzaghi", "/").unwrap_err();
        assert!(e.to_string().contains("no section"), "{e}");
        assert!(parse_params_yaml("- 1\n", "f", "terzaghi", "/").is_err());
        assert!(parse_params_yaml(":\n  :", "f", "terzaghi", "/").is_err());
        assert_eq!(resolve_topic("~/x", "/r", "n", &[]), "/r/n/x");
        assert_eq!(
            resolve_topic("x", "/", "n", &[("/x".into(), "y".into())]),
            "/y"
        );
    }

    #[test]
    fn environment() {
        assert_eq!(domain_id_from_env(None).unwrap(), 0);
        assert_eq!(domain_id_from_env(Some("42")).unwrap(), 42);
        assert!(
            domain_id_from_env(Some("300"))
                .unwrap_err()
                .to_string()
                .contains("300")
        );
        assert!(localhost_only_from_env(Some("LOCALHOST"), None).unwrap());
        assert!(localhost_only_from_env(None, Some("1")).unwrap());
        assert!(!localhost_only_from_env(Some("SUBNET"), None).unwrap());
        assert!(localhost_only_from_env(Some("MOON"), None).is_err());
    }
}
