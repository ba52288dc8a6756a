"""The single Gymnasium env of every task: HopRoverEnv steps one rover through a task's
compiled step (tasks/common.py `build`), draws its episodes (tasks/draws.py, the vector
env's draws for one rover, under the reset options of tasks/options.py), builds
the info dict (envs/parts.py) and renders.

What an env of a task observes, does and pays is the task's: its module's docstring has
the tables (hoprover_env/tasks/torque.py for HopRover-v0). HopRoverEnv itself is the
torque task's env; every other task's subclasses it (hoprover_env/envs/tasks.py).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from hoprover_env import core
from hoprover_env.core.params import P_ROUGH, P_SLOPE, RoverParams
from hoprover_env.envs.parts import (
    NO_TERRAIN_SEED,
    TTRTP_NOT_REACHED,
    check_render_mode,
    full_info,
    task_spaces,
)
from hoprover_env.envs.parts import info as make_info
from hoprover_env.jit import compiler as _compile
from hoprover_env.tasks import draws, reward, torque
from hoprover_env.tasks import options as reset_options
from hoprover_env.tasks.layout import E_T_TOTAL

_NO_LOG = np.zeros((0, core.EV_COLS))
# info's numpy scalars, made once (numpy scalars are immutable)
_NOT_REACHED = np.float64(TTRTP_NOT_REACHED)
_STATE_CODE = tuple(np.int64(code) for code in range(len(core.MODE_LETTERS)))
_COUNT = tuple(np.int64(n) for n in range(256))


def check_actions(action, shape, what="action") -> np.ndarray:
    """float64 array of the expected shape, or ValueError naming the problem. The shape
    may omit its trailing 1 ((n,) for (n, 1); a scalar for (1,)); strings, booleans and
    complex numbers are refused, not converted, and so are other shapes of the same
    size ((1, 4) or (2, 2) for 4 sub-envs)."""
    a = np.asarray(action)
    if a.dtype.kind not in "iuf":
        raise ValueError(
            f"{what} must be real numbers, got {type(action).__name__} {action!r} (dtype {a.dtype})"
        )
    if a.shape != tuple(shape) and a.shape != tuple(shape[:-1]):
        raise ValueError(f"{what} must have shape {tuple(shape)}, got shape {a.shape}")
    a = a.astype(np.float64).reshape(shape)
    if not np.all(np.isfinite(a)):
        bad = np.flatnonzero(~np.isfinite(a.ravel()))
        raise ValueError(f"{what} must be finite, got {a.ravel()[bad[0]]!r} (flat index {bad[0]})")
    return a


class HopRoverEnv(gym.Env):
    """A hoprover task as a Gymnasium env; this class is the torque task's (HopRover-v0,
    HopRoverContest-v0: its tables are in hoprover_env/tasks/torque.py), and every other
    task's env class is this one with its own `task` (hoprover_env/envs/tasks.py).
    Keyword arguments are the task config's (unknown names raise TypeError, arguments
    the task does not use too); render_mode is None, "rgb_array" or "human"."""

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 30}
    task = torque.TASK  # the written interface (tasks/common.py TaskSpec)

    def __init__(self, render_mode: str | None = None, **kwargs: Any):
        self.config = self.task.config.from_kwargs(f"{type(self).__name__}.__init__", **kwargs)
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.action_space, self.observation_space = task_spaces(self.task, self.config)
        self._o = self.config.options_vector()
        # cold cache: compile on 2 cores, for the ground the config's episodes are on
        _compile.prepare(self.task.compile_extra, rough=self.config.draws_bumps())
        self._step_kernel = None  # chosen at reset, by the ground
        self._e = self.config.task_vector()
        self._rw = self.config.reward_vector()
        self._rm = reward.new_memory()
        self._m = self.task.new_memory()
        self._obs = np.zeros(self.observation_space.shape[-1], dtype=np.float32)
        self._a = np.zeros(self.task.action_dim)
        self.terrain_seed = None
        self._w = np.zeros(core.N_WORK)
        # the episode's state and parameter rows: empty until the first reset
        self._s: np.ndarray = np.empty(0)
        self._p: np.ndarray = np.empty(0)
        self._done = False
        self._params: RoverParams | None = self.config.params
        self._keys = draws.RoverKeys(1)
        self._row = np.zeros(1, dtype=np.int64)
        self.target_x = 0.0
        self._renderer = None
        self._trace: list = []

    # ------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode: returns (observation, info). `seed` keys the episode draws
        (target, randomised parameters, terrain, a task's own: tasks/draws.py) and
        restarts the episode count; without it the next episode of the last seed (or of
        a seed from OS entropy) is drawn. `options` fix what the draws would decide
        (tasks/options.py: "target_x" [m], "initial_state" (x, y, theta, vx, vy, omega),
        "slope" and "roughness" [rad], "terrain_seed", a randomised parameter's value, a
        task's own start options), so that a frozen episode starts as it was frozen.
        Raises ValueError naming an unknown or bad option, or for a state no contact
        state allows."""
        super().reset(seed=seed)
        self._start(seed, reset_options.check(self.task, options))
        self._rm[:] = reward.new_memory()
        self._episode = (
            np.float64(self.target_x),
            np.float64(self._p[P_SLOPE]),
            np.int64(NO_TERRAIN_SEED if self.terrain_seed is None else self.terrain_seed),
        )
        self.task.observe(self._s, self._p, self._e, self._m, self._obs)
        self._trace = []
        self._done = False
        if self.render_mode is not None:
            self._trace.append((float(self._s[core.S_X]), float(self._s[core.S_Y])))
            if self.render_mode == "human":
                self.render()
        return self._obs.copy(), self._info(0)

    def _start(self, seed, options: dict) -> None:
        """The episode: the vector env's draws for one rover, under checked options."""
        keys = self._keys
        if seed is None:
            keys.next_episode(self._row)
        else:
            keys.seed_rows(self._row, [seed])
        ep = draws.sample_episodes(self.task, self.config, keys.lo, keys.hi, keys.episode, options)
        self._s, self._p = ep.S[0], ep.P[0]
        self._params = None
        self.target_x = float(ep.targets[0])
        seed = int(ep.terrain_seeds[0])
        self.terrain_seed = None if seed == NO_TERRAIN_SEED else seed
        self._step_kernel = self.task.kernels(
            self.config.integrator, rough=self._p[P_ROUGH] > 0.0
        ).step
        m = self._m[None, :]
        self.task.start_rows(self.config, ep.U, ep.S, ep.P, m, ep.fixed)

    @property
    def params(self):
        """The RoverParams of the episode (built on demand)."""
        if self._params is None:
            self._params = draws.row_params(self._p)
        return self._params

    def step(self, action):
        """Hold the torque `action` maps to for one control period. Returns (observation,
        reward, terminated, truncated, info). Raises ValueError for a non-finite or
        misshapen action and gymnasium.error.ResetNeeded before reset or after the end."""
        if self._s.size == 0:
            raise gym.error.ResetNeeded("call reset() before step()")
        if self._done:
            raise gym.error.ResetNeeded(
                "the episode has ended (terminated or truncated): call reset() before step()"
            )
        a = self._a
        if type(action) is np.ndarray and action.shape == a.shape and action.dtype.kind == "f":
            a[:] = action  # the common case, kept cheap
            if not math.isfinite(a.sum()):
                raise ValueError(f"action must be finite, got {action!r}")
        else:
            a[:] = check_actions(action, a.shape)
        reward, terminated, truncated, _, n_ev = self._step_kernel(
            self._s,
            self._p,
            self._o,
            self._e,
            self._rw,
            self._rm,
            self._m,
            a,
            self._obs,
            _NO_LOG,
            self._w,
        )
        if self.render_mode is not None:
            self._trace.append((float(self._s[core.S_X]), float(self._s[core.S_Y])))
            if self.render_mode == "human":
                self.render()
        self._done = bool(terminated or truncated)
        return self._obs.copy(), float(reward), bool(terminated), bool(truncated), self._info(n_ev)

    def end_cause(self) -> str | None:
        """Why the last step ended the episode: "broken" (a break, or the kernel stopping
        on an error, which ends an episode as a break does), "time" (the episode's clock ran
        out, even where the judge's success came in that same last step), "success";
        None before reset and while the episode runs."""
        if self._s.size == 0 or not self._done:
            return None
        if self._s[core.S_BROKEN] != 0.0 or self._s[core.S_ERROR] != 0.0:
            return "broken"
        if self._s[core.S_T] >= self._e[E_T_TOTAL]:
            return "time"
        return "success"

    def continue_episode(self) -> None:
        """Let an episode that ended in success go on: the rover keeps its state and the
        judge its TTRTP, so the next step pays no second bonus (a goal-conditioned
        learner that keeps going after success, hoprover_env/envs/goal.py). A rover that
        broke or ran out of time stays ended (ResetNeeded; `end_cause` tells which)."""
        cause = self.end_cause()
        if cause is None:
            raise gym.error.ResetNeeded(
                "continue_episode() follows a step that ended the episode in success"
            )
        if cause != "success":
            raise gym.error.ResetNeeded(
                "the episode ended in a break or at the time limit: call reset()"
            )
        self._done = False

    def _info(self, n_events: int) -> dict:
        # numpy scalars of fixed dtype from the first step: TorchRL's info reader wants a
        # .dtype, and it and Tianshou's buffer refuse None and NaN. Indexing a float64
        # array gives a float64 scalar and the rest come from tables, made once (a numpy
        # scalar built per key, or a dict keyed by numpy bools, cost 10 us a step).
        s = self._s
        ttrtp = s[core.S_TTRTP]
        reached = ttrtp == ttrtp  # not NaN
        info = make_info(
            np.True_ if reached else np.False_,
            ttrtp if reached else _NOT_REACHED,
            _STATE_CODE[int(s[core.S_MODE])],
            self._episode[0],
            np.True_ if s[core.S_BROKEN] != 0.0 else np.False_,
            _COUNT[n_events] if n_events < len(_COUNT) else np.int64(n_events),
            self._episode[1],
            self._episode[2],
        )
        if self.config.info_level == "full":
            info.update(full_info(s, self._p, self._rm))
            if self.task.hidden_info is not None:
                info.update(self.task.hidden_info(self._m))
        return info

    # ------------------------------------------------------------------------------
    def render(self):
        """The current frame (an RGB array) with render_mode="rgb_array"; draws the
        window with "human"; None (and a warning) without a render_mode."""
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render_mode; "
                'e.g. gym.make("HopRover-v0", render_mode="rgb_array")'
            )
            return None
        if self._s.size == 0:
            raise gym.error.ResetNeeded("call reset() before render()")
        if self._renderer is None:
            from hoprover_env.envs.rendering import Renderer

            self._renderer = Renderer(mode=self.render_mode, fps=self.metadata["render_fps"])
        s = self._s
        return self._renderer.draw(
            s,
            self.params,
            self.target_x,
            self._trace,
            float(s[core.S_T]),
            core.MODE_LETTERS[int(s[core.S_MODE])],
            float(s[core.S_TORQUE]),
        )

    def __getstate__(self):
        # a pygame window/font cannot be pickled or deep-copied; render() rebuilds it on demand
        state = self.__dict__.copy()
        state["_renderer"] = None
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)

    def close(self):
        """Close the renderer's window, if any."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
