"""HopRover: hop a 1 kg cube across an asteroid to a target, by spinning a torquer.

## Description

The 8th Spacecraft Control System Design Contest (2015) problem. A cube of side 0.1 m
stands upright on flat ground under g = 9.8e-5 m/s^2. Its only actuator is an internal
torquer (|T| <= 5e-4 N m). Torque tips the rover about a bottom corner, which pivots or
slides, until the contact force vanishes and the rover hops; it flies for tens to
hundreds of seconds, bounces (restitution 0.8 horizontal, 0.2 vertical), slides and
stops. The goal: keep a bottom corner within +-0.05 m of the target for 5 s, as early as
possible (the contest's "time to reach the target point", TTRTP). Physics:
`docs/PHYSICS.md` and docs/MODEL.md; every event (lift-off, impact, band crossing) is
located exactly, so TTRTP is exact.

## Action space

`Box(-1, 1, (1,), float32)`, held for one control period (`control_dt`, default 0.5 s).
`action_map="linear"` (the default, the contest's task) maps [-1, 1] linearly onto
[T_min, T_max] = [-5e-4, 5e-4] N m. The rover tips at m g r = 4.9e-6 N m, 1 % of the
range, so resting needs |a| < 0.01 and an exploration noise of std 1 (SB3's default)
means random full-scale torques. `action_map="cubic"` (T = a^3 T_max) puts zero torque
at a = 0 and the tipping torque at |a| ~ 0.2; `action_scale` (default 1) shrinks the
range either way. Out-of-range actions are clipped; a NaN or infinite action raises
`ValueError`.

## Observation space

`Box(float32, (19,))`. Every component is of order one:

| Num | Observation | Scaling | Min | Max |
|-----|-------------|---------|-----|-----|
| 0 | c.m. x relative to the target | / 1 m, clipped | -5 | 5 |
| 1 | c.m. height above its resting height h | / 0.5 m, clipped | -1 | 10 |
| 2 | c.m. horizontal velocity | / 0.01 m/s, clipped | -10 | 10 |
| 3 | c.m. vertical velocity | / 0.01 m/s, clipped | -10 | 10 |
| 4 | sin(theta) (theta clockwise-positive) | | -1 | 1 |
| 5 | cos(theta) | | -1 | 1 |
| 6 | angular rate omega | / 0.3 rad/s, clipped | -10 | 10 |
| 7-13 | contact state A..G, one-hot | | 0 | 1 |
| 14 | time / episode time | | 0 | 1 |
| 15 | judge: time in the band / 5 s (0 when out) | | 0 | 1 |
| 16 | contact point (nearest bottom corner in flight) minus target | / 0.05 m (band half-widths), clipped | -20 | 20 |
| 17 | ballistic landing point of the c.m. minus target (current x when not flying) | / 1 m, clipped | -5 | 5 |
| 18 | torque applied during the last period | / T_max | -1 | 1 |

Components 0-6, 14 and the state are what the contest controller saw (position,
velocity, attitude, rate, target, time, state); 15-18 are closed forms of them.

## Rewards

Per step: `gamma * Phi(s') - Phi(s) - time_cost * (seconds simulated)`, plus
`success_bonus` when the judge's TTRTP is reached and minus `break_penalty` when a top
corner hits the ground, minus `energy_weight` times the step's effort (the integral of
|T| / T_limit over the step's seconds, whatever torques the task applied inside it; 0 by
default). The potential

    Phi(s) = -dist_weight * min(|x_ref - x_T|, dist_cap) / 1 m
             - attitude_weight * a(s) - band_weight * (1 - d(s))

shapes the reward without changing the optimal policy (Ng et al. 1999). x_ref is the
contact point, or in flight the bottom corner nearest the target (`shaping="contact"`)
or the ballistic landing point (`shaping="landing"`, so a hop is credited at launch).
a(s) = (1 - cos theta) + 50 ln(1 + min(u, 5000) / 50), u = (omega / 0.3 rad/s)^2 / 2,
in flight only (0 in contact): an upright, still flight pays at once, long before a bad
landing would be penalised. It is the quadratic cost u up to about 2 rad/s, grows
logarithmically beyond (PPO settled for spinning flights under terms that weakened
earlier) and is constant past 30 rad/s. d(s) is the judge's clock (time in the band / 5 s, 0 out of it), so
settling in the band pays before the bonus and hovering next to it does not.

Every term is bounded, so Phi >= phi_min = -(dist_weight dist_cap + 232.8 attitude_weight
+ band_weight). At termination Phi is 0 on success; when the rover breaks it is set so
that the breaking step's shaping term is exactly 0: breaking cannot release a potential
(with Phi = 0 there, spinning up and crashing once paid up to +142), its reward is
-break_penalty minus the time cost, and a breaking episode keeps every potential it lost
on the way. The time cost makes a faster TTRTP
pay. Defaults: dist_weight 1, dist_cap 5 m, attitude_weight 0, band_weight 0.5,
time_cost 1/600 per second (-1 over a full episode), success_bonus 10, break_penalty 10,
gamma 0.99 (set it to your algorithm's discount).

## Starting state

Upright at rest at x = 0 (state F). The target is drawn uniformly from `target_range`
(default [-1, 1] m) each episode, unless `target_x` is fixed (HopRoverContest-v0: 0.5 m)
or given as `reset(options={"target_x": ...})`. With `randomize`, the physical
parameters are re-drawn each episode from the env's own generator.

## Episode end

* Termination: success (TTRTP reached; `info["ttrtp"]` records it) or the rover broke.
* Truncation: the simulated time reaches `episode_time` (default 600 s, the contest's).

## Info

Every value is a numpy scalar (the vector env: an array) of fixed dtype and shape
from the first step (no None, no NaN, no string), so that any RL library's buffer can
store it (TorchRL's info reader wants a `.dtype`; TorchRL and Tianshou refuse None and NaN):

| Key | Type | Meaning |
|---|---|---|
| `is_success` | bool | the judge's TTRTP has been reached |
| `ttrtp` | float64 | the TTRTP [s] once reached; -1.0 before (`TTRTP_NOT_REACHED`) |
| `state` | int64 | contact state code 0..6 = A..G (`"ABCDEFG"[code]`: 0 flight, 5 at rest) |
| `target_x` | float64 | the target [m] |
| `broken` | bool | a top corner hit the ground |
| `n_events` | int64 | events located during the step |
| `slope` | float64 | the ground's inclination this episode [rad] |
| `terrain_seed` | int64 | the seed of this episode's rough-terrain bumps (replay it with `simulate(..., seed=)`); -1 on smooth ground |

`info_level="full"` adds `t` (s), `rover_state` (x, y, theta, vx, vy, omega),
`contact_forces` (fAx, fAy, fBx, fBy; single env) and the reward's terms
`reward_distance`, `reward_attitude`, `reward_band`, `reward_time`, `reward_bonus`,
`reward_penalty`, `reward_energy`, which sum to the reward (up to rounding; hoprover_env/tasks/reward.py).

## Arguments

| Argument | Default | Description |
|---|---|---|
| `control_dt` | 0.5 | control period [s] |
| `episode_time` | 600.0 | truncation time [s] |
| `target_range` | (-1, 1) | targets drawn from U(low, high) [m] |
| `target_x` | None | a fixed target instead [m] |
| `integrator` | "event" | "event" (exact events) or "euler" (contest-style fixed step) |
| `impact_law` | "contest" | "contest" or "dissipative" |
| `rtol`, `euler_dt` | 1e-11, 1e-3 | integrator accuracy |
| `params` | RoverParams() | physical parameters (a RoverParams or a dict) |
| `randomize` | None | relative half-ranges, e.g. {"mu_static": 0.2, "gravity": 0.3} |
| `dist_weight`, `time_cost`, `success_bonus`, `break_penalty`, `gamma` | 1, 1/600, 10, 10, 0.99 | reward |
| `shaping` | "contact" | potential in flight: "contact" or "landing" |
| `attitude_weight` | 0.0 | weight of the flight-attitude potential |
| `band_weight` | 0.5 | weight of the judge's-clock potential |
| `dist_cap` | 5.0 | distances beyond this [m] count as this |
| `energy_weight` | 0.0 | weight of the effort: the integral of abs(T) / T_limit over each step [s] |
| `action_map`, `action_scale` | "linear", 1.0 | action -> torque map and its range fraction |
| `info_level` | "basic" | "full" adds state and forces to info |
| `render_mode` | None | "rgb_array" or "human" |

## Version history

* v0: the contest's task (2015 model, exact events); info values numeric since the
  library-compatibility release (`ttrtp` -1.0 before success, `state` an integer code).

## Vectorized environment

`gym.make_vec("HopRover-v0", num_envs=N)` returns `HopRoverVectorEnv`, which steps all
sub-envs in one jitted call; `hoprover_env.envs.sb3.HopRoverSB3VecEnv` is the same for
Stable-Baselines3. The hop-level task, one action per hop: `HopRoverHop-v0`
(hop_env.py).
"""
from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from hoprover_env import core
from hoprover_env.jit import compiler as _compile
from hoprover_env.tasks import reward
from hoprover_env.tasks.config import sample_episode
from hoprover_env.core.params import P_ROUGH
from hoprover_env.envs.parts import (NO_TERRAIN_SEED, TTRTP_NOT_REACHED, check_render_mode, full_info,
                        info as make_info, task_spaces)
from hoprover_env.tasks import torque

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
        raise ValueError(f"{what} must be real numbers, got {type(action).__name__} "
                         f"{action!r} (dtype {a.dtype})")
    if a.shape != tuple(shape) and a.shape != tuple(shape[:-1]):
        raise ValueError(f"{what} must have shape {tuple(shape)}, got shape {a.shape}")
    a = a.astype(np.float64).reshape(shape)
    if not np.all(np.isfinite(a)):
        bad = np.flatnonzero(~np.isfinite(a.ravel()))
        raise ValueError(f"{what} must be finite, got {a.ravel()[bad[0]]!r} "
                         f"(flat index {bad[0]})")
    return a


class HopRoverEnv(gym.Env):
    """The torque task as a Gymnasium env: HopRover-v0 and HopRoverContest-v0 (this
    module's docstring has the tables). Keyword arguments are EnvConfig's (unknown names
    raise TypeError); render_mode is None, "rgb_array" or "human"."""
    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 30}
    task = torque.TASK          # the written interface (tasks/common.py TaskSpec)

    def __init__(self, render_mode: str | None = None, **kwargs: Any):
        self.config = self.task.config.from_kwargs(f"{type(self).__name__}.__init__",
                                                   **kwargs)
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.action_space, self.observation_space = task_spaces(self.task, self.config)
        self._o = self.config.options_vector()
        # cold cache: compile on 2 cores, for the ground the config's episodes are on
        _compile.prepare(self.task.compile_extra, rough=self.config.draws_bumps())
        self._step_kernel = None                        # chosen at reset, by the ground
        self._e = self.config.task_vector()
        self._rw = self.config.reward_vector()
        self._rm = reward.new_memory()
        self._m = self.task.new_memory()
        self._obs = np.zeros(self.observation_space.shape[-1], dtype=np.float32)
        self._a = np.zeros(self.task.action_dim)
        self.terrain_seed = None
        self._w = np.zeros(core.N_WORK)
        self._s = None
        self._p = None
        self._done = False
        self.params = self.config.params
        self.target_x = 0.0
        self._renderer = None
        self._trace: list = []

    # ------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode: returns (observation, info). `seed` seeds the env's generator
        (target, randomised parameters, terrain); `options` may fix "target_x" [m],
        "initial_state" (x, y, theta, vx, vy, omega), "slope" and "roughness" [rad].
        Raises ValueError for an unknown option or a state no contact state allows."""
        super().reset(seed=seed)
        self.target_x, self.params, self._s, self._p, self.terrain_seed = sample_episode(
            self.config, self.np_random, options)
        self._rm[:] = reward.new_memory()
        # the build without rough-terrain code while the ground is smooth (core/smooth.py)
        self._step_kernel = self.task.kernels(self.config.integrator,
                                              rough=self._p[P_ROUGH] > 0.0).step
        self.task.start(self.config, self.np_random, self._s, self._p, self._m)
        self._episode = (np.float64(self.target_x), np.float64(self.params.slope),
                         np.int64(NO_TERRAIN_SEED if self.terrain_seed is None
                                  else self.terrain_seed))
        self.task.observe(self._s, self._p, self._e, self._m, self._obs)
        self._trace = []
        self._done = False
        if self.render_mode is not None:
            self._trace.append((float(self._s[core.S_X]), float(self._s[core.S_Y])))
            if self.render_mode == "human":
                self.render()
        return self._obs.copy(), self._info(0)

    def step(self, action):
        """Hold the torque `action` maps to for one control period. Returns (observation,
        reward, terminated, truncated, info). Raises ValueError for a non-finite or
        misshapen action and gymnasium.error.ResetNeeded before reset or after the end."""
        if self._s is None:
            raise gym.error.ResetNeeded("call reset() before step()")
        if self._done:
            raise gym.error.ResetNeeded("the episode has ended (terminated or truncated): "
                                        "call reset() before step()")
        a = self._a
        if type(action) is np.ndarray and action.shape == a.shape and action.dtype.kind == "f":
            a[:] = action                           # the common case, kept cheap
            if not math.isfinite(a.sum()):
                raise ValueError(f"action must be finite, got {action!r}")
        else:
            a[:] = check_actions(action, a.shape)
        reward, terminated, truncated, _, n_ev = self._step_kernel(
            self._s, self._p, self._o, self._e, self._rw, self._rm, self._m, a, self._obs,
            _NO_LOG, self._w)
        if self.render_mode is not None:
            self._trace.append((float(self._s[core.S_X]), float(self._s[core.S_Y])))
            if self.render_mode == "human":
                self.render()
        self._done = bool(terminated or truncated)
        return self._obs.copy(), float(reward), bool(terminated), bool(truncated), \
            self._info(n_ev)

    def _info(self, n_events: int) -> dict:
        # numpy scalars of fixed dtype from the first step: TorchRL's info reader wants a
        # .dtype, and it and Tianshou's buffer refuse None and NaN. Indexing a float64
        # array gives a float64 scalar and the rest come from tables, made once (a numpy
        # scalar built per key, or a dict keyed by numpy bools, cost 10 us a step).
        s = self._s
        ttrtp = s[core.S_TTRTP]
        reached = ttrtp == ttrtp                      # not NaN
        info = make_info(np.True_ if reached else np.False_,
                         ttrtp if reached else _NOT_REACHED, _STATE_CODE[int(s[core.S_MODE])],
                         self._episode[0], np.True_ if s[core.S_BROKEN] != 0.0 else np.False_,
                         _COUNT[n_events] if n_events < len(_COUNT) else np.int64(n_events),
                         self._episode[1], self._episode[2])
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
            gym.logger.warn("render() called without a render_mode; "
                            'e.g. gym.make("HopRover-v0", render_mode="rgb_array")')
            return None
        if self._s is None:
            raise gym.error.ResetNeeded("call reset() before render()")
        if self._renderer is None:
            from hoprover_env.envs.rendering import Renderer
            self._renderer = Renderer(mode=self.render_mode, fps=self.metadata["render_fps"])
        s = self._s
        return self._renderer.draw(s, self.params, self.target_x, self._trace,
                                   float(s[core.S_T]), core.MODE_LETTERS[int(s[core.S_MODE])],
                                   float(s[core.S_TORQUE]))

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
