"""HopRoverVectorEnv: N rovers stepped in one jitted call over flat arrays.

    envs = gym.make_vec("HopRover-v0", num_envs=4096)            # this class
    envs = HopRoverVectorEnv(256, autoreset_mode="SameStep", threads=True)

Every sub-env runs its task's step (hoprover_env/tasks), the code `HopRoverEnv` runs, on a
row of a 2-D state array; resets draw as the single env does (seed s gives sub-env i the
seed s + i, as Gymnasium's SyncVectorEnv): every row reset at once in one vectorised
draw keyed by (the sub-env's seed, its episode number) (hoprover_env/tasks/draws.py), under
the reset options of hoprover_env/tasks/options.py. So sub-env i and `HopRoverEnv` seeded
with s + i agree bit for bit.

Arguments: those of HopRoverEnv, plus `num_envs`, `autoreset_mode` (NextStep, the
default, or SameStep), `max_episode_steps` (an extra step limit per episode) and
`threads` (None: threaded from 64 sub-envs on; True/False to force). Infos follow
Gymnasium's dict-of-arrays convention (each key with its `_key` mask); with SameStep,
`final_obs` and `final_info` carry the ended episodes' last observation and info. The
info values and their types are those of HopRoverEnv (the table in env.py), as arrays.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from hoprover_env import core
from hoprover_env.core.params import N_PARAMS, P_ROUGH, P_SLOPE
from hoprover_env.envs.env import check_actions
from hoprover_env.envs.parts import (
    NO_TERRAIN_SEED,
    check_render_mode,
    full_info,
    object_rows,
    task_spaces,
)
from hoprover_env.envs.parts import info as make_info
from hoprover_env.jit import compiler as _compile
from hoprover_env.jit.spread import spread_order
from hoprover_env.jit.threads import run_threaded
from hoprover_env.tasks import draws, reward, torque
from hoprover_env.tasks import options as reset_options
from hoprover_env.tasks.common import note_info_rows

THREAD_THRESHOLD = 64


def _threaded_step(batch_threaded, order, *args):
    """The task's threaded batch step over the rows in `order`, leaving the caller's
    OpenMP settings as they were (jit.threads.run_threaded)."""
    return run_threaded(batch_threaded, *args, order)


class HopRoverVectorEnv(VectorEnv):
    """N rovers of the torque task stepped in one jitted call (the module docstring has
    the arguments); sub-env i equals a HopRoverEnv seeded with seed + i."""

    metadata = {
        "render_modes": ["rgb_array"],
        "render_fps": 30,
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }
    task = torque.TASK  # the written interface (tasks/common.py TaskSpec)

    def __init__(
        self,
        num_envs: int = 1,
        autoreset_mode=AutoresetMode.NEXT_STEP,
        max_episode_steps: int | None = None,
        threads: bool | None = None,
        render_mode: str | None = None,
        **kwargs: Any,
    ):
        if not (
            isinstance(num_envs, (int, np.integer))
            and not isinstance(num_envs, bool)
            and num_envs >= 1
        ):
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        self.config = self.task.config.from_kwargs(f"{type(self).__name__}.__init__", **kwargs)
        # cold cache: compile on 2 cores, for the ground the config's episodes are on
        _compile.prepare(self.task.compile_extra, rough=self.config.draws_bumps())
        self.num_envs = int(num_envs)
        mode: AutoresetMode | None
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            mode = (
                AutoresetMode[str(autoreset_mode).upper()]
                if str(autoreset_mode).upper() in AutoresetMode.__members__
                else None
            )
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(f"autoreset_mode must be NextStep or SameStep, got {autoreset_mode!r}")
        self.autoreset_mode = mode
        self.metadata = {**type(self).metadata, "autoreset_mode": mode}
        if max_episode_steps is not None and not (
            isinstance(max_episode_steps, (int, np.integer)) and max_episode_steps >= 1
        ):
            raise ValueError(
                f"max_episode_steps must be a positive integer or None, got {max_episode_steps!r}"
            )
        self.max_episode_steps = max_episode_steps
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.threads = (self.num_envs >= THREAD_THRESHOLD) if threads is None else bool(threads)
        self._rough: bool | None = None
        # chosen at reset, by the ground (_choose_kernel)
        self._kernel: Callable[..., Any] | None = None

        self.single_action_space, self.single_observation_space = task_spaces(
            self.task, self.config
        )
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)

        n = self.num_envs
        self._o = self.config.options_vector()
        self._e = self.config.task_vector()
        self._rw = self.config.reward_vector()
        self._rm = reward.new_memory(n)
        self.M = self.task.new_memory(n)
        self.S = np.zeros((n, core.N_STATE))
        self.P = np.zeros((n, N_PARAMS))
        self._obs = np.zeros((n, self.single_observation_space.shape[0]), dtype=np.float32)
        self._rew = np.zeros(n)
        self._term = np.zeros(n, dtype=np.bool_)
        self._trunc = np.zeros(n, dtype=np.bool_)
        self._succ = np.zeros(n, dtype=np.bool_)
        self._nev = np.zeros(n, dtype=np.int64)
        self._autoreset = np.zeros(n, dtype=np.bool_)
        self._steps = np.zeros(n, dtype=np.int64)
        self._max_steps = 0 if max_episode_steps is None else int(max_episode_steps)
        self._ended = np.zeros(n, dtype=np.bool_)
        # the info columns, one contiguous array each (TTRTP, reached, state code,
        # broken), written by the step kernel for the rows it steps and by _note_info for
        # the rows reset; the slope changes at resets only
        self._info_columns = (
            np.zeros(n),
            np.zeros(n, dtype=np.bool_),
            np.zeros(n, dtype=np.int64),
            np.zeros(n, dtype=np.bool_),
        )
        self._slope = np.zeros(n)
        self._all = np.ones(n, dtype=np.bool_)
        self._log = np.zeros((0, core.EV_COLS))
        self._work = np.zeros((numba.config.NUMBA_NUM_THREADS, core.N_WORK))
        self._order = spread_order(n)  # the rows in the order the threaded step reads them
        self.targets = np.zeros(n)
        self.terrain_seeds = np.full(n, NO_TERRAIN_SEED, dtype=np.int64)
        self._params = draws.ParamsView(self.P)
        self._keys = draws.RoverKeys(n)
        self._observe_rows = self.task.observer()
        self._traces: list = [[] for _ in range(n)] if render_mode else []
        self._renderers: list = []
        self._ready = False
        self._note_info(np.arange(n))  # those of the all-zero rows of a sub-env never reset

    # ------------------------------------------------------------------------------
    def _choose_kernel(self, rough: bool | np.bool_) -> None:
        """The batch kernel for the ground: without rough-terrain code while every rover
        is on smooth ground (core/smooth.py), the general one once any has bumps."""
        rough = bool(rough)
        if rough != self._rough:
            kernels = self.task.kernels(self.config.integrator, rough=rough)
            # a threaded step leaves the caller's OpenMP thread count (torch's) as it was,
            # and reads the rovers in an order that gives each thread a fair share of
            # the costly ones (jit.spread)
            self._kernel = (
                functools.partial(_threaded_step, kernels.batch_threaded, self._order)
                if self.threads
                else kernels.batch
            )
            self._rough = rough

    @property
    def params(self):
        """The RoverParams of each sub-env's episode (params[i]; built on demand)."""
        return self._params

    def _reset_rows(self, rows: np.ndarray, options=None):
        """New episodes of the sub-envs in `rows`: one draw for all, keyed by each one's
        seed and episode number (hoprover_env/tasks/draws.py), under `options` (checked,
        one row per sub-env)."""
        keys = self._keys
        ep = draws.sample_episodes(
            self.task,
            self.config,
            keys.lo[rows],
            keys.hi[rows],
            keys.episode[rows],
            None if options is None else {k: v[rows] for k, v in options.items()},
        )
        self.S[rows] = ep.S
        self.P[rows] = ep.P
        self._params.forget(rows)
        self.targets[rows] = ep.targets
        self.terrain_seeds[rows] = ep.terrain_seeds
        self._steps[rows] = 0
        self._rm[rows] = reward.new_memory()
        m = self.task.new_memory(len(rows))
        self.task.start_rows(self.config, ep.U, ep.S, ep.P, m, ep.fixed)
        self.M[rows] = m
        if not self._rough and (ep.P[:, P_ROUGH] > 0.0).any():  # an autoreset onto bumps
            self._choose_kernel(True)
        self._observe_rows(self.S, self.P, self._e, self.M, self._obs, rows)
        self._note_info(rows)
        if self.render_mode:
            for i in rows:
                self._traces[i] = [(float(self.S[i, core.S_X]), float(self.S[i, core.S_Y]))]

    def _note_info(self, rows: np.ndarray) -> None:
        """The info columns of `rows` (int64 indices) from their state and parameter
        rows: those the step kernel does not write, of rows reset outside it."""
        note_info_rows(self.S, rows, *self._info_columns)
        self._slope[rows] = self.P[rows, P_SLOPE]

    def reset(self, *, seed: int | list | None = None, options: dict | None = None):
        """Reset the sub-envs (all, or those in options["reset_mask"]). `seed` is an int
        (sub-env i gets seed + i) or one per sub-env (None entries: no new seed); a
        sub-env given no seed draws the next episode of its last one (one never seeded:
        base + i, base a seed from OS entropy drawn once per call); the reset options
        (hoprover_env/tasks/options.py: "target_x", "initial_state", "slope", "roughness",
        "terrain_seed", randomised parameters' values, the task's start options) take a
        value or one per sub-env. Returns (observations, infos)."""
        super().reset(seed=int(seed) if isinstance(seed, (int, np.integer)) else None)
        n = self.num_envs
        first: int | None = None  # an int seed: sub-env i's is first + i
        if seed is None or isinstance(seed, (int, np.integer)):
            seeds = None
            first = None if seed is None else int(seed)
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(f"seed list has {len(seeds)} entries for {n} envs")
        options = dict(options or {})
        mask = np.asarray(options.pop("reset_mask", self._all), dtype=np.bool_)
        if mask.shape != (n,):
            raise ValueError(f"options['reset_mask'] must have shape ({n},), got {mask.shape}")
        per_env = reset_options.check(self.task, options, n, per_rover=True, also=("reset_mask",))
        rows = np.flatnonzero(mask)
        keys = self._keys
        if first is not None:
            keys.seed_consecutive(first, rows)
        elif seeds is not None:
            given = np.array([seeds[i] is not None for i in rows], dtype=np.bool_)
            keys.seed_rows(rows[given], [seeds[i] for i in rows[given]])
            keys.next_episode(rows[~given])
        else:
            keys.next_episode(rows)
        self._reset_rows(rows, per_env or None)
        self._choose_kernel((self.P[:, P_ROUGH] > 0.0).any())
        self._autoreset[mask] = False
        self._ready = True
        return self._obs.copy(), self._infos(np.zeros(n, dtype=np.int64))

    def step(self, actions):
        """Step every active sub-env: actions of shape (N, action_dim) (or (N,) for one
        component). Returns (observations, rewards, terminated, truncated, infos); raises
        ValueError for a non-finite or misshapen action, RuntimeError before reset."""
        if not self._ready:
            raise RuntimeError("call reset() before step()")
        n = self.num_envs
        shape = (n, self.task.action_dim)
        if (
            type(actions) is np.ndarray
            and actions.shape == shape
            and actions.dtype == np.float64
            and actions.flags.c_contiguous
        ):
            a = actions  # the common case; finiteness checked in the kernel
        else:
            a = np.ascontiguousarray(check_actions(actions, shape, "actions"))
        if self.autoreset_mode == AutoresetMode.NEXT_STEP and self._autoreset.any():
            active = ~self._autoreset
            self._autoreset_rows(np.flatnonzero(self._autoreset))
        else:
            active = self._all
        # the kernel also counts the episodes' steps, truncates at max_episode_steps,
        # flags the ended episodes and writes the info columns (tasks/common.py
        # close_row), each row while it is in its thread's cache; the rows not stepped get
        # the outputs of a reset (idle_row)
        bad = self._kernel(
            self.S,
            self.P,
            self._o,
            self._e,
            self._rw,
            self._rm,
            self.M,
            a,
            active,
            self._obs,
            self._rew,
            self._term,
            self._trunc,
            self._succ,
            self._nev,
            self._log,
            self._work,
            self._steps,
            self._max_steps,
            self._ended,
            *self._info_columns,
        )
        if bad >= 0:
            raise ValueError(f"actions must be finite, got {a[bad].tolist()!r} for sub-env {bad}")
        if self.render_mode:
            for i in range(n):
                self._traces[i].append((float(self.S[i, core.S_X]), float(self.S[i, core.S_Y])))
        ended = self._ended
        if self.autoreset_mode == AutoresetMode.SAME_STEP and ended.any():
            idx = np.flatnonzero(ended)
            final_info = self._infos(self._nev, mask=ended)
            final_obs = np.full(n, None, dtype=object)
            final_obs[idx] = object_rows(self._obs[idx])
            self._autoreset_rows(idx)
            infos = self._infos(self._nev)
            infos["final_obs"], infos["_final_obs"] = final_obs, ended.copy()
            infos["final_info"], infos["_final_info"] = final_info, ended.copy()
        else:
            infos = self._infos(self._nev)
            np.copyto(self._autoreset, ended)
        return (self._obs.copy(), self._rew.copy(), self._term.copy(), self._trunc.copy(), infos)

    def _autoreset_rows(self, rows) -> None:
        self._keys.next_episode(rows)
        self._reset_rows(rows)

    def _infos(self, nev, mask=None) -> dict:
        n = self.num_envs
        mask = np.ones(n, dtype=np.bool_) if mask is None else mask.copy()
        ttrtp, reached, mode, broken = self._info_columns
        info = make_info(
            reached.copy(),
            ttrtp.copy(),
            mode.copy(),
            self.targets.copy(),
            broken.copy(),
            nev.astype(np.int64),
            self._slope.copy(),
            self.terrain_seeds.copy(),
        )
        if self.config.info_level == "full":
            info.update(full_info(self.S, self.P, self._rm))
            if self.task.hidden_info is not None:
                info.update(self.task.hidden_info(self.M))
        for key in list(info):
            info["_" + key] = mask  # one mask array shared by all keys of this step
        return info

    # ------------------------------------------------------------------------------
    def render(self):
        """One RGB frame per sub-env (render_mode="rgb_array"), or None."""
        if self.render_mode is None:
            return None
        from hoprover_env.envs.rendering import Renderer

        while len(self._renderers) < self.num_envs:
            self._renderers.append(Renderer(mode="rgb_array"))
        frames = []
        for i in range(self.num_envs):
            s = self.S[i]
            frames.append(
                self._renderers[i].draw(
                    s,
                    self.params[i],
                    self.targets[i],
                    self._traces[i],
                    float(s[core.S_T]),
                    core.MODE_LETTERS[int(s[core.S_MODE])],
                    float(s[core.S_TORQUE]),
                )
            )
        return tuple(frames)

    def close_extras(self, **kwargs):
        """Close the sub-envs' renderers."""
        for r in getattr(self, "_renderers", ()):  # None if __init__ refused its arguments
            r.close()
        self._renderers = []
