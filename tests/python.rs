//! The Python package (`python/`, pyo3 and maturin) as a user installs it: `pip install
//! ./python` into a venv of its own (`target/pyvenv`, made on first use; needs PyPI), then its
//! pytest suite (`python/tests`: the API against this build's `terzaghi` on the same inputs)
//! and the README's Python example as written. Beside it, in a venv of its own
//! (`target/peervenv`, from `python/benchmarks/requirements-peers.txt`; torch from PyPI is
//! about 6 GB installed, and its download runs while the package's tests do),
//! `python/tests_peers`: CPU tensors and JAX arrays in and out without a copy, an
//! accelerator's refused, and every peer of `python/benchmarks/peers.py` equal to
//! `terzaghi.batch`.

mod common;

use common::{repo, terzaghi};
use std::path::PathBuf;
use std::process::Command;

/// The venv with the package built from this checkout.
fn python_with_package() -> PathBuf {
    common::python_venv("target/pyvenv", "python/tests/requirements.txt")
}

#[test]
fn the_python_package_passes_its_tests_and_the_readme_example_runs() {
    let py = python_with_package();
    let tmp = tempfile::tempdir().unwrap();
    let out = Command::new(&py)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(repo().join("python/tests"))
        .env("TERZAGHI_BIN", terzaghi())
        .current_dir(tmp.path())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    eprintln!("{text}");
    assert!(
        out.status.success(),
        "pytest failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The README's Python example, as written (run where a user's shell would be: the clone).
    let readme = std::fs::read_to_string(repo().join("README.md")).unwrap();
    let start = readme
        .find("```python\n")
        .expect("README.md has a Python example");
    let body = &readme[start + "```python\n".len()..];
    let example = &body[..body.find("```").unwrap()];
    let out = Command::new(&py)
        .args(["-c", example])
        .current_dir(repo())
        .output()
        .unwrap();
    let printed = String::from_utf8_lossy(&out.stdout);
    eprintln!("{printed}");
    assert!(
        out.status.success(),
        "the README's example failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(printed.contains("b_k"), "{printed}");
}

/// The torch and JAX interop and the benchmark's peers (numba, numpy, `torch.compile`): torch
/// from PyPI is 6 GB, so this runs where `TERZAGHI_PEER_TESTS=1` asks for it (CI always does),
/// and says it was skipped elsewhere.
#[test]
fn torch_and_jax_arrays_go_through_the_batch_in_place_and_every_peer_agrees() {
    if std::env::var("TERZAGHI_PEER_TESTS").as_deref() != Ok("1") {
        eprintln!(
            "skipped: the torch and JAX peers (a 6 GB download) run with TERZAGHI_PEER_TESTS=1"
        );
        return;
    }
    let py = common::python_venv(
        "target/peervenv",
        "python/benchmarks/requirements-peers.txt",
    );
    let tmp = tempfile::tempdir().unwrap();
    let out = Command::new(&py)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(repo().join("python/tests_peers"))
        .env("TERZAGHI_BIN", terzaghi())
        .current_dir(tmp.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "pytest python/tests_peers failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
