//! What a user relies on when a command writes: an output is never one of its inputs (by the
//! same path, a relative one or a link), and every command ends with the exit code
//! `docs/command-line.md` states: 0 done, 1 failed (an output that cannot be written), 2 bad
//! input (usage, impossible geometry, a cut-off recording, a refusal).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// The paper's testbed plate in its sand, as flags.
const GEOM: [&str; 12] = common::SAND_GEOM;

fn terzaghi_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(common::terzaghi())
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .expect("run terzaghi")
}

fn code(out: &Output) -> i32 {
    out.status.code().expect("an exit code, not a signal")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A scratch directory with a CSV log (`log.csv`, 6 strokes of the testbed's plate), the node's
/// parameters for it (`params.yaml`) and a recording of the walking robot (`walk.mcap`).
struct Scratch {
    _tmp: tempfile::TempDir,
    dir: PathBuf,
}

impl Scratch {
    fn new() -> Scratch {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().to_path_buf();
        let mut sim = vec!["simulate", "--bk", "2", "--a", "1.5", "--strokes", "6"];
        sim.extend(GEOM);
        sim.extend(["-o", "log.csv"]);
        assert_eq!(code(&terzaghi_in(&dir, &sim)), 0);
        std::fs::write(dir.join("params.yaml"), common::LEG_PARAMS).unwrap();
        let walk = terzaghi_in(
            &dir,
            &["simulate-robot", "--seconds", "5", "-o", "walk.mcap"],
        );
        assert_eq!(code(&walk), 0, "{}", stderr(&walk));
        Scratch { _tmp: tmp, dir }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    fn run(&self, args: &[&str]) -> Output {
        terzaghi_in(&self.dir, args)
    }

    /// `args` with the testbed's geometry after them.
    fn run_geom(&self, args: &[&str]) -> Output {
        let all: Vec<&str> = args.iter().chain(GEOM.iter()).copied().collect();
        self.run(&all)
    }
}

/// Refused with exit 2, the input named, and the input's bytes as they were.
fn assert_input_kept(s: &Scratch, input: &str, out: Output) {
    let before = std::fs::read(s.path(input)).unwrap();
    let err = stderr(&out);
    assert_eq!(code(&out), 2, "{err}");
    assert!(err.contains("is the input") && err.contains(input), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        std::fs::read(s.path(input)).unwrap(),
        before,
        "{input} changed"
    );
}

#[test]
fn an_output_that_is_an_input_is_refused_by_every_command() {
    let s = Scratch::new();
    let abs = s.path("log.csv");
    let abs = abs.to_str().unwrap();
    std::os::unix::fs::symlink("log.csv", s.path("link.csv")).unwrap();
    std::os::unix::fs::symlink("walk.mcap", s.path("link.mcap")).unwrap();
    let log_before = std::fs::read(s.path("log.csv")).unwrap();

    // identify --trace: the same path, a relative one, an absolute one, a link.
    for trace in ["log.csv", "./log.csv", abs, "link.csv"] {
        let out = s.run_geom(&["identify", "log.csv", "--online", "--trace", trace]);
        assert_input_kept(&s, "log.csv", out);
    }
    let out = s.run_geom(&[
        "identify",
        "log.csv",
        "--online",
        "--trace-plot",
        "link.csv",
    ]);
    assert_input_kept(&s, "log.csv", out);
    // replay --reevaluate: the log, and the parameters file.
    for (output, input) in [
        ("log.csv", "log.csv"),
        ("./link.csv", "log.csv"),
        ("params.yaml", "params.yaml"),
    ] {
        let out = s.run(&[
            "replay",
            "log.csv",
            "--reevaluate",
            "--params-file",
            "params.yaml",
            "-o",
            output,
        ]);
        assert_input_kept(&s, input, out);
    }
    let out = s.run(&[
        "replay",
        "walk.mcap",
        "--reevaluate",
        "-o",
        "link.mcap",
        "--overwrite",
    ]);
    assert_input_kept(&s, "walk.mcap", out);
    // diagnose: its output directory is the log, or one of the files it writes is the log.
    let out = s.run_geom(&["diagnose", "log.csv", "--out", "log.csv"]);
    assert_input_kept(&s, "log.csv", out);
    std::fs::create_dir(s.path("d")).unwrap();
    std::fs::copy(s.path("log.csv"), s.path("d/report.json")).unwrap();
    let out = s.run_geom(&["diagnose", "d/report.json", "--out", "d"]);
    assert_input_kept(&s, "d/report.json", out);
    // recover and import-dem: their one output.
    let out = s.run(&["recover", "walk.mcap", "-o", "./link.mcap", "--overwrite"]);
    assert_input_kept(&s, "walk.mcap", out);
    let out = s.run(&["import-dem", "log.csv", "-o", "link.csv", "--overwrite"]);
    assert_input_kept(&s, "log.csv", out);
    // fit (and identify) print to standard output: appended to the log, refused as cat does.
    for cmd in ["fit", "identify"] {
        let log = std::fs::OpenOptions::new()
            .append(true)
            .open(s.path("log.csv"))
            .unwrap();
        let out = Command::new(common::terzaghi())
            .arg(cmd)
            .arg("log.csv")
            .args(GEOM)
            .current_dir(&s.dir)
            .stdout(log)
            .output()
            .unwrap();
        let err = stderr(&out);
        assert_eq!(code(&out), 2, "{cmd}: {err}");
        assert!(
            err.contains("standard output is the input log.csv"),
            "{err}"
        );
    }
    assert_eq!(std::fs::read(s.path("log.csv")).unwrap(), log_before);
    // The node's recording and its parameters file (refused before any DDS participant).
    let out = isolated_node(
        &s.dir,
        &[
            "--record",
            "params.yaml",
            "--overwrite",
            "--ros-args",
            "--params-file",
            "params.yaml",
        ],
    );
    assert_input_kept(&s, "params.yaml", out);
    // `simulate`, `simulate-robot`, `record` and `demo` read no file: there is nothing to refuse.
}

/// `terzaghi node ARGS`, in the private network namespace (the refusal comes before DDS starts,
/// but a node is never run outside one).
fn isolated_node(dir: &Path, args: &[&str]) -> Output {
    common::isolated_command(&common::terzaghi())
        .arg("node")
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

/// Every command: 0 when done, 1 when an output cannot be written (a path under a regular
/// file), 2 on bad input, each failure with one `error:` line on stderr and no panic.
#[test]
fn exit_codes_per_command() {
    let s = Scratch::new();
    let full = std::fs::read(s.path("walk.mcap")).unwrap();
    std::fs::write(s.path("cut.mcap"), &full[..full.len() / 2]).unwrap();
    // A session of the testbed's plate at b_k 2, a 1.5, with `extra`.
    let simulate = |extra: &[&'static str]| -> Vec<&'static str> {
        [&["simulate", "--bk", "2", "--a", "1.5"], extra].concat()
    };
    let cases: Vec<(&str, Vec<&str>, i32)> = vec![
        (
            "predict",
            vec!["predict", "--beta-deg", "60", "--bk", "2", "--a", "1.5"],
            0,
        ),
        ("simulate", simulate(&["--strokes", "2", "-o", "s.csv"]), 0),
        ("simulate bad", simulate(&["--strokes", "0"]), 2),
        (
            "simulate unwritable",
            simulate(&["--strokes", "2", "-o", "log.csv/s.csv"]),
            1,
        ),
        ("fit", vec!["fit", "log.csv"], 0),
        ("fit bad", vec!["fit", "params.yaml"], 2),
        (
            "identify",
            vec!["identify", "log.csv", "--online", "--trace", "t.csv"],
            0,
        ),
        (
            "identify unwritable",
            vec![
                "identify",
                "log.csv",
                "--online",
                "--trace",
                "log.csv/t.csv",
            ],
            1,
        ),
        ("diagnose", vec!["diagnose", "log.csv", "--out", "diag"], 0),
        (
            "diagnose cut",
            vec!["diagnose", "cut.mcap", "--out", "diag2"],
            2,
        ),
        (
            "diagnose unwritable",
            vec!["diagnose", "log.csv", "--out", "log.csv/diag"],
            1,
        ),
    ];
    // Commands that take the geometry flags, and those that do not.
    let no_geom: Vec<(&str, Vec<&str>, i32)> = vec![
        (
            "predict impossible",
            vec![
                "predict",
                "--beta-deg",
                "60",
                "--length-m",
                "0.1",
                "--width-m",
                "0.06",
                "--hip-height-m",
                "0.15",
                "--medium",
                "hit_sand",
            ],
            2,
        ),
        ("media", vec!["media"], 0),
        ("info", vec!["info", "walk.mcap"], 0),
        ("info cut", vec!["info", "cut.mcap"], 2),
        (
            "replay",
            vec!["replay", "walk.mcap", "--reevaluate", "-o", "rows.csv"],
            0,
        ),
        (
            "replay cut",
            vec!["replay", "cut.mcap", "--reevaluate", "-o", "rows2.csv"],
            2,
        ),
        (
            "replay unwritable",
            vec!["replay", "walk.mcap", "--reevaluate", "-o", "log.csv/r.csv"],
            1,
        ),
        (
            "recover",
            vec!["recover", "cut.mcap", "-o", "fixed.mcap"],
            0,
        ),
        (
            "recover not mcap",
            vec!["recover", "log.csv", "-o", "fixed2.mcap"],
            2,
        ),
        (
            "recover unwritable",
            vec!["recover", "cut.mcap", "-o", "log.csv/f.mcap"],
            1,
        ),
        (
            "simulate-robot",
            vec!["simulate-robot", "--seconds", "1", "-o", "w2.mcap"],
            0,
        ),
        (
            "simulate-robot bad",
            vec!["simulate-robot", "--seconds=-1", "-o", "w3.mcap"],
            2,
        ),
        (
            "simulate-robot unwritable",
            vec!["simulate-robot", "--seconds", "1", "-o", "log.csv/w.mcap"],
            1,
        ),
        (
            "import-dem bad",
            vec!["import-dem", "log.csv", "-o", "dem.mcap"],
            2,
        ),
        (
            "record bad",
            vec!["record", "--topics", "/x:no/such/Type", "-o", "r.mcap"],
            2,
        ),
        ("demo bad", vec!["demo", "--speed", "0"], 2),
        ("usage", vec!["predict", "--frobnicate"], 2),
    ];
    let with_geom = cases
        .into_iter()
        .map(|(name, args, want)| (name, [args.as_slice(), &GEOM].concat(), want));
    let mut failures = Vec::new();
    for (name, args, want) in with_geom.chain(no_geom) {
        let out = s.run(&args);
        let err = stderr(&out);
        let got = code(&out);
        let error_lines = err.lines().filter(|l| l.starts_with("error:")).count();
        if got != want || err.contains("panicked") || (want != 0 && error_lines != 1) {
            failures.push(format!(
                "{name}: exit {got}, expected {want}, {error_lines} error lines: {err:?}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A misspelled parameter, at the top level or nested, is refused with the nearest known name
/// wherever node parameters are read: `replay`'s `-p` and its parameters file (the node reads
/// them through the same check, `config::check_keys`).
#[test]
fn a_misspelled_parameter_is_refused_with_the_nearest_name() {
    let s = Scratch::new();
    let out = s.run(&[
        "replay",
        "walk.mcap",
        "--reevaluate",
        "-p",
        "use_identifed:=false",
        "-o",
        "rows.csv",
    ]);
    let err = stderr(&out);
    assert_eq!(code(&out), 2, "{err}");
    assert!(
        err.contains("use_identifed") && err.contains("did you mean use_identified?"),
        "{err}"
    );
    let nested = common::LEG_PARAMS.to_string() + "    estimator:\n      memory_strokez: 4.0\n";
    std::fs::write(s.path("typo.yaml"), nested).unwrap();
    let out = s.run(&[
        "replay",
        "log.csv",
        "--reevaluate",
        "--params-file",
        "typo.yaml",
        "-o",
        "rows.csv",
    ]);
    let err = stderr(&out);
    assert_eq!(code(&out), 2, "{err}");
    assert!(
        err.contains("estimator.memory_strokez")
            && err.contains("did you mean estimator.memory_strokes?"),
        "{err}"
    );
    assert!(!s.path("rows.csv").exists(), "nothing written");
}
