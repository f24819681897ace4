"""terzaghi.batch with the arrays of the learning stacks: CPU torch tensors and JAX arrays are
read and written where they lie (DLPack), accelerator arrays refused with what to do; and every
peer of python/benchmarks/peers.py equals terzaghi.batch before it is timed. Run by
tests/python.rs in target/peervenv (python/benchmarks/requirements-peers.txt)."""

import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import torch

import terzaghi
from terzaghi.batch import LegBatch, _view

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import peers  # noqa: E402

LEG = dict(length_m=0.1, width_m=0.025)
C_LEG = dict(model="rft", medium="poppy_lp", shape="c_leg", rft_elements=96)


def _legs(shape, dtype=np.float64):
    rng = np.random.default_rng(2)
    return (rng.uniform(0.0, 2 * np.pi, shape).astype(dtype),
            rng.uniform(0.0, 0.06, shape).astype(dtype),
            rng.uniform(2.0, 8.0, shape).astype(dtype))


def test_torch_tensors_are_read_and_written_in_place():
    beta, hip, omega = (torch.from_numpy(a) for a in _legs((64, 6)))
    legs = LegBatch(**LEG, **C_LEG)
    # Read where they lie: the batch's view of a tensor is the tensor's memory.
    assert _view("beta_rad", beta).ctypes.data == beta.data_ptr()
    out = tuple(torch.zeros((64, 6), dtype=torch.float64) for _ in range(3))
    ptrs = [o.data_ptr() for o in out]
    got = legs.forces(beta, hip, omega_rad_s=omega, out=out)
    assert all(g is o for g, o in zip(got, out)) and [o.data_ptr() for o in out] == ptrs
    want = legs.forces(beta.numpy(), hip.numpy(), omega_rad_s=omega.numpy())
    for g, w in zip(out, want):
        np.testing.assert_array_equal(g.numpy(), w)
    assert torch.count_nonzero(out[1]) > 0
    # Without out=, tensors come back.
    fresh = legs.forces(beta, hip, omega_rad_s=omega)
    assert all(isinstance(f, torch.Tensor) and f.dtype == torch.float64 for f in fresh)
    np.testing.assert_array_equal(fresh[0].numpy(), want[0])
    # float32 tensors make a float32 batch.
    f32 = legs.forces(beta.float(), hip.float(), omega_rad_s=omega.float())
    assert all(f.dtype == torch.float32 for f in f32)


def test_jax_arrays_are_read_in_place_and_come_back_as_jax():
    b, h, w = _legs((32, 6), np.float32)
    beta, hip, omega = jnp.asarray(b), jnp.asarray(h), jnp.asarray(w)
    assert beta.dtype == jnp.float32  # JAX's default
    assert _view("beta_rad", beta).ctypes.data == beta.unsafe_buffer_pointer()
    legs = LegBatch(**LEG, **C_LEG)
    got = legs.forces(beta, hip, omega_rad_s=omega)
    assert all(isinstance(g, jax.Array) and g.dtype == jnp.float32 for g in got)
    want = legs.forces(b, h, omega_rad_s=w)
    for g, x in zip(got, want):
        np.testing.assert_array_equal(np.asarray(g), x)
    # JAX arrays are immutable: out= of them is refused, by name.
    with pytest.raises(terzaghi.TerzaghiError, match="drag_n is read-only"):
        legs.forces(beta, hip, out=tuple(jnp.zeros((32, 6), jnp.float32) for _ in range(3)))


def test_an_array_off_the_cpu_is_refused_with_what_to_do():
    legs = LegBatch(**LEG, **C_LEG)
    off = torch.empty((4, 6), dtype=torch.float64, device="meta")
    with pytest.raises(terzaghi.TerzaghiError, match=r"beta_rad is on meta.*x\.cpu\(\)"):
        legs.forces(off, 0.01)
    with pytest.raises(terzaghi.TerzaghiError, match=r"hip_height_m is on meta"):
        legs.forces(np.zeros((4, 6)), off)


def test_every_peer_equals_terzaghi_batch():
    # The benchmark's own check (it exits naming the peer that differs), at a smaller size.
    peers.SHAPE = (256, 6)
    sys.argv = ["peers.py", "--threads", "1", "--check-only"]
    peers.main()
