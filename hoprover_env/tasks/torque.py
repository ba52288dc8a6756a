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
earlier) and is constant past 30 rad/s. d(s) is the judge's clock (time in the band / 5 s,
0 out of it), so settling in the band pays before the bonus and hovering next to it does not.

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
parameters are re-drawn each episode from the episode's seed. Reset options fix what the
draws would decide (hoprover_env/tasks/options.py): `target_x`, `initial_state`, `slope`,
`roughness`, `terrain_seed` and the value of any randomised parameter (`mass`,
`mu_static`, ...), so that an env started with a frozen episode's options plays it.

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
`reward_penalty`, `reward_energy`, which sum to the reward (up to rounding;
hoprover_env/tasks/reward.py).

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
(hoprover_env/tasks/hop.py).

## The step, in the kernel

The torque task (HopRover-v0, HopRoverContest-v0): one action is the torque held for
one control period, as in the contest.

`action_to_torque` maps the action; the step advances the rover by one control period
and ends as every task does (tasks/common.py `close_step`). `TASK` is its written
interface (tasks/common.py `TaskSpec`); the step's actuator is a placeholder,
``ACTUATE``, that a task built on this step may bind to its own (the mission task's
carries a per-episode scale error).

Its step calls these jitted functions: `common.open_step`, `ACTUATE` (bound to
`commanded_torque`, i.e. `action_to_torque`), `ADVANCE` (bound by `common.build` to
`core.advance_event`, or `core.advance` for `integrator="euler"`), `reward.charge` and
`common.close_step`; then `observation.observe`.
"""  # noqa: E501 (Markdown tables, rendered by docs/_ext/envpages.py: a row cannot wrap)

import numpy as np

from hoprover_env.core.layout import S_T
from hoprover_env.core.params import P_TMAX, P_TMIN
from hoprover_env.jit.compiler import F64, VEC, kernel
from hoprover_env.tasks import Registration, reward
from hoprover_env.tasks.common import ADVANCE, TaskSpec, close_step, open_step
from hoprover_env.tasks.config import RL_SETTINGS, EnvConfig
from hoprover_env.tasks.layout import (
    ACTION_CUBIC,
    ACTION_MAPS,
    E_ACTION_MAP,
    E_ACTION_SCALE,
    E_CONTROL_DT,
    E_T_TOTAL,
)
from hoprover_env.tasks.observation import OBS_HIGH, OBS_LOW, clip, observe


@kernel(F64(F64, VEC, VEC))
def action_to_torque(a, P, E):
    """Box(-1, 1) onto the torque range [N m]; out-of-range actions are clipped.

    linear (the contest's task): [-1, 1] -> [T_min, T_max]. cubic: T = a^3 T_max for
    a >= 0 and |a|^3 T_min below, so zero torque sits at a = 0 and the fine torques that
    tip the rover (about 1 % of T_max) are 0.2 of the action range instead of 0.01.
    Either is then scaled by action_scale (the fraction of the range reached at |a| = 1).
    """
    a = clip(a, -1.0, 1.0)
    if int(E[E_ACTION_MAP]) == ACTION_CUBIC:
        c = a * a * a
        t = c * P[P_TMAX] if c >= 0.0 else -c * P[P_TMIN]
    else:
        t = P[P_TMIN] + 0.5 * (a + 1.0) * (P[P_TMAX] - P[P_TMIN])
    return E[E_ACTION_SCALE] * t


def torque_to_action(torque: float, params, config=None) -> float:
    """The inverse of `action_to_torque` for a rover of `params` (a RoverParams) under
    `config`'s action map and scale (linear and 1 without a config), clipped to
    [-1, 1]: the action a controller that commands `torque` [N m] takes."""
    lo, hi = params.torque_min, params.torque_max
    amap = getattr(config, "action_map", "linear")
    scale = getattr(config, "action_scale", 1.0)
    t = torque / scale
    if ACTION_MAPS.get(amap) == ACTION_CUBIC:
        ref = hi if t >= 0.0 else -lo
        if ref <= 0.0:
            return 0.0
        return float(np.clip(np.cbrt(t / ref), -1.0, 1.0))
    if hi == lo:
        return 0.0
    return float(np.clip(2.0 * (t - lo) / (hi - lo) - 1.0, -1.0, 1.0))


def step(S, P, O, E, RW, RM, M, action, ev, W):
    """One control period with the torque `action` maps to. Returns (reward, terminated,
    truncated, success, n_events)."""
    phi0, had_ttrtp, t0, nev0 = open_step(S, P, RW, RM)
    torque = ACTUATE(action, P, E, M)
    ADVANCE(S, P, O, torque, min(t0 + E[E_CONTROL_DT], E[E_T_TOTAL]), ev, W)
    reward.charge(P, RM, torque, S[S_T] - t0)
    return close_step(S, P, E, RW, RM, phi0, had_ttrtp, t0, nev0)


def ACTUATE(action, P, E, M):
    """Placeholder in `step`: the torque [N m] an action row commands, bound per task
    (TaskSpec.holes)."""
    raise NotImplementedError("ACTUATE is bound by tasks.common.build")


@kernel(inner=True)
def commanded_torque(action, P, E, M):
    """The torque task's actuator: exactly the torque `action_to_torque` maps to."""
    return action_to_torque(action[0], P, E)


TASK = TaskSpec(
    name="torque",
    config=EnvConfig,
    step=step,
    observe=observe,
    obs_low=OBS_LOW,
    obs_high=OBS_HIGH,
    holes={"ACTUATE": commanded_torque},
    action_torque=action_to_torque,
    torque_action=torque_to_action,
    compile_extra=(open_step, close_step, action_to_torque, observe),
)
REGISTER = (
    Registration("HopRover-v0", suite="level"),
    Registration("HopRoverContest-v0", {"target_x": 0.5}, suite="contest"),
    Registration("HopRoverRL-v0", RL_SETTINGS, suite="level"),
)
