"""What one decision at rest is worth: the return of an episode that opens with one
torque held for a control period and then follows a fixed rule, as a function of that
torque. It is the landscape an off-policy actor climbs with the critic's gradient dQ/da.

    python -m research.offpolicy.landscape --out benchmarks/results/offpolicy/landscape.csv

For each action map (linear, cubic) and each opening action a on a grid over [-1, 1],
the rover starts upright at rest with the target at `--target` m, holds a for one control
period (HopRoverRL-v0's settings: 2 s, its reward), and then follows one of two rules:

- `none`: zero torque for the rest of the episode (what a policy that has learnt only
  to keep still does after the opening);
- `hold`: in flight, the hop task's attitude hold T = -I (kp theta + kd omega) with its
  gains, clipped to the torque limit, held for each 2 s period; zero torque on the
  ground. The best a learner could hope to have learnt about flying before it learns
  to launch, with no retargeting.

Each row: map, rule, a, the episode's discounted return (the learner's gamma, from the
opening state: Q(s0, a) under that rule), its undiscounted return, whether it broke,
succeeded, and where the rover ended relative to the target. Written atomically.

The learners bootstrap at the 600 s truncation (SB3 reads `TimeLimit.truncated`): for
them an episode cut by the clock goes on. So the discounted return here follows the rule
past the limit (`--horizon`, 4800 s: the discount there is below 1e-5 of the first
step's) and is the value a converged critic would give; `discounted_return_cut` is the
same return stopped at the 600 s limit, without bootstrapping, which is what this table
showed before and undervalues resting (a whole episode at rest: -2.37 cut, -3.05
bootstrapped, at HopRoverRL-v0's settings).
"""

from __future__ import annotations

import argparse
import csv
import io
import math
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import numpy as np

import hoprover_env  # noqa: F401  (registers the ids)
from hoprover_env.agents.policies import torque_to_action
from hoprover_env.core.params import RoverParams
from hoprover_env.sim.controllers import attitude_hold
from hoprover_env.tasks.config import RL_SETTINGS
from hoprover_env.tasks.hop import HopEnvConfig
from hoprover_env.tasks.observation import OBS_COS, OBS_DX, OBS_MODE, OBS_RATE, OBS_SIN, RATE_SCALE
from hoprover_env.util.files import atomic_write

PARAMS = RoverParams()  # the ids' default rover
HOLD_KP, HOLD_KD = HopEnvConfig.hold_kp, HopEnvConfig.hold_kd  # the hop task's defaults
FIELDS = [
    "action_map",
    "rule",
    "action",
    "discounted_return",
    "discounted_return_cut",
    "return",
    "broken",
    "success",
    "final_offset_m",
    "steps",
]
LIMIT = 600.0  # the ids' episode_time [s]


def follow_up(rule: str, obs: np.ndarray, action_map: str) -> float:
    """The action after the opening: zero, or the attitude hold in flight (contact
    state A, the first of the one-hot components) in the action map's units."""
    if rule == "none" or obs[OBS_MODE] < 0.5:
        return 0.0
    torque = attitude_hold(
        math.atan2(obs[OBS_SIN], obs[OBS_COS]),
        obs[OBS_RATE] * RATE_SCALE,
        PARAMS.inertia,
        HOLD_KP,
        HOLD_KD,
    )
    return torque_to_action(torque, PARAMS, SimpleNamespace(action_map=action_map))


def episode(action_map: str, rule: str, a: float, target: float, horizon: float) -> dict:
    env = gym.make("HopRoverRL-v0", action_map=action_map, target_x=target, episode_time=horizon)
    obs, _ = env.reset(seed=0)
    gamma, ret, disc, cut = RL_SETTINGS["gamma"], 0.0, 0.0, 0.0
    steps_in_limit = int(round(LIMIT / RL_SETTINGS["control_dt"]))
    for k in range(1_000_000):
        act = a if k == 0 else follow_up(rule, obs, action_map)
        obs, r, term, trunc, info = env.step(np.array([act], dtype=np.float32))
        disc += gamma**k * float(r)
        if k < steps_in_limit:
            ret += float(r)
            cut += gamma**k * float(r)
            end_info, end_obs, end_k = info, obs, k
        if term or trunc:
            break
    env.close()
    info, obs = end_info, end_obs  # the episode as the ids end it, at the 600 s limit
    return {
        "action_map": action_map,
        "rule": rule,
        "action": round(a, 4),
        "discounted_return": round(disc, 4),
        "discounted_return_cut": round(cut, 4),
        "return": round(ret, 4),
        "broken": bool(info["broken"]),
        "success": bool(info["is_success"]),
        "final_offset_m": round(float(obs[OBS_DX]), 4),
        "steps": end_k + 1,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="the CSV to write")
    ap.add_argument("--target", type=float, default=0.5, help="target x [m]")
    ap.add_argument("--points", type=int, default=81, help="actions on the grid over [-1, 1]")
    ap.add_argument(
        "--horizon",
        type=float,
        default=4800.0,
        help="simulated seconds the rule is followed for the bootstrapped value",
    )
    args = ap.parse_args(argv)
    if args.points < 3:
        ap.error(f"--points must be at least 3, got {args.points}")
    if args.horizon < LIMIT:
        ap.error(f"--horizon must be at least the {LIMIT:g} s limit, got {args.horizon}")
    rows = [
        episode(m, rule, float(a), args.target, args.horizon)
        for m in ("linear", "cubic")
        for rule in ("none", "hold")
        for a in np.linspace(-1, 1, args.points)
    ]
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=FIELDS)
    writer.writeheader()
    writer.writerows(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out, buf.getvalue())
    for m in ("linear", "cubic"):
        for rule in ("none", "hold"):
            sel = [r for r in rows if r["action_map"] == m and r["rule"] == rule]
            print(
                f"{m:6s} {rule:4s}: broken {sum(r['broken'] for r in sel)}/{len(sel)}, "
                f"success {sum(r['success'] for r in sel)}/{len(sel)}, best discounted "
                f"return {max(r['discounted_return'] for r in sel):+.2f} at a = "
                f"{max(sel, key=lambda r: r['discounted_return'])['action']:+.3f}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
