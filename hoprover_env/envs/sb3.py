"""Stable-Baselines3 VecEnv over the native batched core: SB3 trains on N rovers with
no subprocesses and no per-env Python objects.

    from hoprover_env.envs.sb3 import HopRoverSB3VecEnv
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize
    venv = VecNormalize(VecMonitor(HopRoverSB3VecEnv(64, seed=0)), norm_reward=False)
    PPO("MlpPolicy", venv).learn(100_000)

It follows SB3's VecEnv contract: same-step reset, `terminal_observation` and
`TimeLimit.truncated` in the info of an env that ended, `is_success` (read by SB3's
success-rate logging and EvalCallback) and the judge's `ttrtp` (-1.0 if not reached;
the info table in env.py). Environment arguments
are those of `HopRoverEnv`; `seed` seeds sub-env i with seed + i, as `VecEnv.seed` does;
`env_id` picks the task (HopRover-v0, HopRoverContest-v0 or the hop-level HopRoverHop-v0).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from hoprover_env.envs.registry import ENVS, vector_env_class


class HopRoverSB3VecEnv(VecEnv):
    """N rovers as one Stable-Baselines3 ``VecEnv``, stepped by the native vector env.

    Parameters: `num_envs` sub-envs (>= 1); `seed` (int or None) seeds sub-env i with
    seed + i at the next reset; `threads` (None: threaded from 64 sub-envs on, or
    True/False); `render_mode` (None or "rgb_array"); `env_id` one of `hoprover_env.ENVS`
    (its fixed arguments apply); `env_kwargs` the env's arguments (the tables on the
    environment pages: control_dt [s], episode_time [s], target_range [m], reward
    weights, ...).

    Observations are float32 (num_envs, obs_dim) (19 for the torque task, 20 on terrain),
    rewards float32 (num_envs,), actions (num_envs, 1) in [-1, 1]. `step_seconds`
    accumulates the wall time [s] spent in `step_wait` (the env's share of training
    time).

    Raises ValueError (an unknown `env_id`, a bad env argument, a non-finite action at
    `step_wait`) and TypeError (an unknown env argument), naming the argument.
    """

    def __init__(
        self,
        num_envs: int = 1,
        seed: int | None = None,
        threads: bool | None = None,
        render_mode: str | None = None,
        env_id: str = "HopRover-v0",
        **env_kwargs: Any,
    ):
        cls = vector_env_class(env_id)
        env_kwargs = {**ENVS[env_id].kwargs, **env_kwargs}
        self.venv = cls(
            num_envs,
            autoreset_mode=AutoresetMode.SAME_STEP,
            threads=threads,
            render_mode=render_mode,
            **env_kwargs,
        )
        self.config = self.venv.config
        super().__init__(
            num_envs, self.venv.single_observation_space, self.venv.single_action_space
        )
        if seed is not None:
            self.seed(seed)
        self._actions: np.ndarray | None = None
        self.step_seconds = 0.0  # wall time spent inside step_wait (the env's share)

    # ---- the VecEnv contract ------------------------------------------------------
    def reset(self):
        """Reset every sub-env (with the seeds of `seed()` and the `target_x` of
        `set_options()`, if given) and return the observations (num_envs, obs_dim). Raises
        ValueError if `target_x` was set for some sub-envs but not all."""
        seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
        targets = [o.get("target_x") for o in self._options]
        options = None
        if any(t is not None for t in targets):
            if any(t is None for t in targets):
                raise ValueError("set_options: give 'target_x' for every env or for none")
            options = {"target_x": np.array(targets, dtype=float)}
        obs, _ = self.venv.reset(seed=seeds, options=options)
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [{} for _ in range(self.num_envs)]
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        """Store `actions` ((num_envs, 1) or (num_envs,), in [-1, 1]) for `step_wait`."""
        self._actions = actions

    def step_wait(self):
        """Step every sub-env one control period (one hop on HopRoverHop-v0). Returns
        (obs, rewards, dones, infos); a sub-env that ended is reset at once and its info
        holds `terminal_observation`, `TimeLimit.truncated`, `is_success`, the judge's
        `ttrtp` [s], `broken`, `target_x` [m] and `state`. Raises ValueError for a
        non-finite action."""
        t0 = time.perf_counter()
        try:
            return self._step()
        finally:
            self.step_seconds += time.perf_counter() - t0

    def _step(self):
        actions = np.asarray(self._actions, dtype=np.float64).reshape(self.num_envs, 1)
        obs, rew, term, trunc, infos = self.venv.step(actions)
        dones = term | trunc
        out = [{} for _ in range(self.num_envs)]
        if dones.any():
            fin, final_obs = infos["final_info"], infos["final_obs"]
            for i in np.flatnonzero(dones):
                out[i] = {
                    "terminal_observation": final_obs[i],
                    "TimeLimit.truncated": bool(trunc[i] and not term[i]),
                    "is_success": bool(fin["is_success"][i]),
                    "ttrtp": float(fin["ttrtp"][i]),
                    "broken": bool(fin["broken"][i]),
                    "target_x": float(fin["target_x"][i]),
                    "state": int(fin["state"][i]),
                }
        return obs, rew.astype(np.float32), dones, out

    def close(self) -> None:
        """Close the vector env (its renderers)."""
        self.venv.close()

    def get_attr(self, attr_name: str, indices=None) -> list:
        """`attr_name` per sub-env in `indices` (default all): "target_x"/"targets" [m]
        and "params" (RoverParams) per sub-env, anything else read from the vector env."""
        idx = self._get_indices(indices)
        if attr_name == "render_mode":
            return [self.venv.render_mode for _ in idx]
        if attr_name in ("target_x", "targets"):
            return [float(self.venv.targets[i]) for i in idx]
        if attr_name == "params":
            return [self.venv.params[i] for i in idx]
        return [getattr(self.venv, attr_name) for _ in idx]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        """Set `attr_name` on the vector env (shared by all sub-envs: `indices` is
        ignored)."""
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list:
        """Call `method_name` on the vector env once and return its result per index
        ("render" returns each sub-env's frame)."""
        idx = self._get_indices(indices)
        if method_name == "render":
            frames = self.venv.render()
            return [frames[i] if frames else None for i in idx]
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result for _ in idx]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        """False per index: the sub-envs are rows of one array, never wrapped."""
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """One RGB frame (H, W, 3) uint8 per sub-env with render_mode "rgb_array", else
        None per sub-env."""
        frames = self.venv.render()
        return list(frames) if frames else [None] * self.num_envs
