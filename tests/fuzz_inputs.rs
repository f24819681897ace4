//! Every input the fuzz targets keep (`fuzz/corpus/<target>/`, the seeds and what a run added
//! that was committed) and every input that once broke a promise (`fuzz/regressions/<target>/`)
//! goes through the same check as `cargo fuzz run <target>` (`terzaghi::fuzzing`): the product
//! reads it or refuses it, and hands on no non-finite number. docs/fuzzing.md says how to run
//! the targets and add a regression.

use std::path::{Path, PathBuf};

/// A target's name and what it runs on an input.
type Target = (&'static str, fn(&[u8]));

const TARGETS: [Target; 10] = [
    ("node_wire", terzaghi::fuzzing::node_wire),
    ("params", terzaghi::fuzzing::params),
    ("csv_log", terzaghi::fuzzing::csv_log),
    ("plate_test", terzaghi::fuzzing::plate_test),
    ("steady_runs", terzaghi::fuzzing::steady_runs),
    ("intrusion_test", terzaghi::fuzzing::intrusion_test),
    ("medium_file", terzaghi::fuzzing::medium_file),
    ("mcap", terzaghi::fuzzing::mcap),
    ("mesh_file", terzaghi::fuzzing::mesh_file),
    ("batch_legs", terzaghi::fuzzing::batch_legs),
];

fn inputs(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

fn replay(kind: &str, min_files: usize) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz")
        .join(kind);
    let mut replayed = 0;
    for (target, run) in TARGETS {
        for file in inputs(&root.join(target)) {
            let data = std::fs::read(&file).expect("a committed input reads");
            let caught = std::panic::catch_unwind(|| run(&data));
            assert!(
                caught.is_ok(),
                "{target} breaks on {} (replay: cargo +nightly fuzz run {target} {} in fuzz/)",
                file.display(),
                file.display()
            );
            replayed += 1;
        }
    }
    println!("{replayed} inputs of fuzz/{kind} replayed");
    assert!(replayed >= min_files, "fuzz/{kind} holds {replayed} inputs");
}

/// The corpora: the seeds from the repository's own files and what the runs kept.
#[test]
fn every_corpus_input_is_read_or_refused() {
    replay("corpus", TARGETS.len());
}

/// Each input a fuzz run found that broke a promise, kept after its fix.
#[test]
fn every_input_that_once_broke_is_read_or_refused() {
    replay("regressions", 0);
}
