//! The Python package beside the stacks a learning user has (torch, JAX) and the peers its
//! batch kernel is measured against (numba, torch.compile): in a venv of their own
//! (`target/peervenv`, from `python/benchmarks/requirements-peers.txt`; torch from PyPI is
//! about 6 GB installed), `python/tests_peers`: CPU tensors and JAX arrays in and out without
//! a copy, an accelerator's refused, and every peer of `python/benchmarks/peers.py` equal to
//! `terzaghi.batch`.

mod common;

use common::{repo, terzaghi};
use std::process::Command;

#[test]
fn torch_and_jax_arrays_go_through_the_batch_in_place_and_every_peer_agrees() {
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
