"""A vectorised Gymnasium environment: the hexapod of :mod:`terzaghi.mujoco` walking on sand,
many copies stepped at once by MuJoCo's rollout with terzaghi's forces on every leg
(:class:`terzaghi.mujoco.BatchCoupling`), each copy on its own medium.

>>> from terzaghi.envs import HexapodSandVecEnv
>>> env = HexapodSandVecEnv(num_envs=1024)
>>> obs, info = env.reset(seed=0)
>>> obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Needs ``mujoco`` and ``gymnasium`` (``pip install mujoco gymnasium``).
"""

from __future__ import annotations

import math
from typing import Any, Dict, Optional, Tuple

import gymnasium
import numpy as np

from .batch import LegBatch
from .mujoco import TRIPOD_A, BatchCoupling, hexapod_legs, hexapod_xml

__all__ = ["HexapodSandVecEnv"]


class HexapodSandVecEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` hexapods (:func:`terzaghi.mujoco.hexapod_xml`) on poppy seeds, each step
    ``frame_skip`` MuJoCo steps of every environment at once.

    - **Action**: each leg servo's speed command (rad/s), ``(num_envs, 6)`` in ``[0, 12]``.
    - **Observation** (float32, ``(num_envs, 29)``): the torso's height (m), orientation
      quaternion (w, x, y, z), linear velocity (world, m/s) and angular velocity (body, rad/s),
      each leg's angle as sine and cosine, and each leg's rate (rad/s).
    - **Reward**: the torso's forward speed along the world's x axis (m/s) over the step.
    - **Termination**: the torso upside down. **Truncation**: after ``max_steps`` steps.
    - **Media**: at every reset each environment draws the improved model's ``b_k`` and ``a``
      uniformly from ``b_k_range`` and ``a_range`` (poppy seeds' fit, 32.61 and 2.30, lies in
      the defaults); ``info["b_k"]``, ``info["a"]`` give them.

    Environments that end are reset in the same step (Gymnasium's ``SAME_STEP`` autoreset):
    their observation and ``info`` are the new episode's, ``info["final_obs"]`` and
    ``info["final_info"]`` the ended one's.
    """

    metadata = {"autoreset_mode": gymnasium.vector.AutoresetMode.SAME_STEP}

    def __init__(self, num_envs: int = 64, *, frame_skip: int = 5, max_steps: int = 1000,
                 b_k_range: Tuple[float, float] = (24.0, 40.0),
                 a_range: Tuple[float, float] = (2.0, 2.6), threads: Optional[int] = None) -> None:
        import mujoco

        for label, (lo, hi) in (("b_k_range", b_k_range), ("a_range", a_range)):
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                raise ValueError(f"{label} = {(lo, hi)!r}: two finite numbers, 0 < low <= high")
        if int(frame_skip) < 1 or int(max_steps) < 1:
            raise ValueError(f"frame_skip = {frame_skip!r}, max_steps = {max_steps!r}: each >= 1")
        self.num_envs = int(num_envs)
        self.frame_skip, self.max_steps = int(frame_skip), int(max_steps)
        self.b_k_range, self.a_range = (float(b_k_range[0]), float(b_k_range[1])), (float(a_range[0]), float(a_range[1]))
        model = mujoco.MjModel.from_xml_string(hexapod_xml())
        self.coupling = BatchCoupling(
            model, hexapod_legs(), LegBatch(length_m=0.1, width_m=0.025, medium="poppy_lp"),
            n_envs=self.num_envs, torso="torso", threads=threads)
        self.model = model
        # The tripods start half a turn apart, as terzaghi.mujoco.walk starts them.
        start = self.coupling.initial_state.copy()
        for i, leg in enumerate(hexapod_legs()):
            start[1 + 7 + i] = 0.8 if leg.name in TRIPOD_A else 0.8 + math.pi
        self._start = start
        self._nq, self._nv = model.nq, model.nv
        self.single_action_space = gymnasium.spaces.Box(0.0, 12.0, (6,), np.float64)
        self.single_observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (29,), np.float32)
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self.observation_space = gymnasium.vector.utils.batch_space(
            self.single_observation_space, self.num_envs)
        self._steps = np.zeros(self.num_envs, dtype=np.int64)
        self._b_k = np.empty(self.num_envs)
        self._a = np.empty(self.num_envs)
        self._rng = np.random.default_rng()

    def _reset_envs(self, which: np.ndarray) -> None:
        self.coupling.state[which] = self._start
        self._steps[which] = 0
        n = int(which.sum()) if which.dtype == bool else len(which)
        self._b_k[which] = self._rng.uniform(*self.b_k_range, n)
        self._a[which] = self._rng.uniform(*self.a_range, n)
        self.coupling.set_media(self._b_k, self._a)

    def _obs(self) -> np.ndarray:
        s = self.coupling.state
        nq, nv = self._nq, self._nv
        q, v = s[:, 1:1 + nq], s[:, 1 + nq:1 + nq + nv]
        return np.concatenate([q[:, 2:7], v[:, :6], np.sin(q[:, 7:]), np.cos(q[:, 7:]), v[:, 6:]],
                              axis=1).astype(np.float32)

    def _info(self) -> Dict[str, Any]:
        return {"b_k": self._b_k.copy(), "a": self._a.copy()}

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        """Every environment at its start, each on a newly drawn medium."""
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        self._reset_envs(np.ones(self.num_envs, dtype=bool))
        return self._obs(), self._info()

    def step(self, actions):
        """Every environment ``frame_skip`` MuJoCo steps on: ``actions`` is ``(num_envs, 6)``
        servo speeds (clipped to ``[0, 12]``; another shape or a non-finite value is a
        ``ValueError`` naming it). Returns observations, rewards, terminations, truncations
        and ``info``."""
        a = np.asarray(actions, dtype=np.float64)
        if a.shape != (self.num_envs, 6):
            raise ValueError(f"actions has shape {a.shape}, expected ({self.num_envs}, 6)")
        if not np.isfinite(a).all():
            bad = np.argwhere(~np.isfinite(a))[0]
            raise ValueError(f"actions[{bad[0]}, {bad[1]}] = {a[tuple(bad)]}: not a number")
        c = self.coupling
        c.ctrl[:] = np.clip(a, 0.0, 12.0)
        x0 = c.state[:, 1].copy()
        for _ in range(self.frame_skip):
            c.step()
        dt = self.frame_skip * self.model.opt.timestep
        reward = (c.state[:, 1] - x0) / dt
        self._steps += 1
        x, y = c.state[:, 5], c.state[:, 6]
        # The torso's z axis's up component, 1 - 2 (x^2 + y^2) of its unit quaternion, below
        # zero: upside down.
        terminated = 1.0 - 2.0 * (x * x + y * y) < 0.0
        truncated = self._steps >= self.max_steps
        obs = self._obs()
        info = self._info()
        done = terminated | truncated
        if done.any():
            final = {"final_obs": obs, "_final_obs": done.copy(), "final_info": info,
                     "_final_info": done.copy()}
            self._reset_envs(done)
            obs = self._obs()
            info = {**self._info(), **final}
        return obs, reward, terminated, truncated, info

    def close(self, **kwargs) -> None:
        """Stops MuJoCo's threads."""
        self.coupling.close()
