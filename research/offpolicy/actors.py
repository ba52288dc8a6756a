"""What a trained off-policy actor does, per contact state, and how large its critic's
action gap is in flight against the one-step reward's.

    python -m research.offpolicy.actors --model runs/sac/checkpoints/model_100000.zip \\
        --episodes 40 --out benchmarks/results/offpolicy/actors_sac.json

Loads an SB3 model saved by train.py (with its _vecnormalize.pkl), plays `--episodes`
episodes with its deterministic actor from rest (the contest's start, seeded targets in
[-1, 1] m) and splits its decisions by the contact state they were taken in:

- rest (state F): the median |a| and the share of decisions whose torque tips a rover at
  rest (|T| > m g r);
- ground contact (B-E, G: pivoting or sliding on a corner or the face);
- flight (A): the median |a|, the median |omega|, the correlation of the torque with
  -omega (1: a damper that brakes the spin), and the 90th percentile of |theta| (how far
  from upright it flies).

For SAC, TQC and CrossQ also the actor's pre-tanh mean mu in every state: its median
|mu| and the share of decisions with |mu| > SATURATED (5: tanh's slope below 2e-4, so
the critic's gradient hardly reaches mu there; past about 10 it is 0 in float32 and the
action stays at +-1 whatever the critic learns; training/actor_penalty.py).

In every state also what the learner's exploration adds to the actor's action there: the
median spread of its exploring action (SAC and TQC: the state's Gaussian standard
deviation through the tanh squashing's slope at the mean; TD3: its action noise) and the
mean probability that an exploring action's torque tips a rover at rest (|T| > m g r).

Per episode: broken (and, for each break, the contact state of the decision that led to
it: `broken_from`), success, whether it ended in flight (cut by the 600 s limit before
landing), the median flight's duration (decisions in a row in flight, times the control
period) and that of each episode's longest flight, the opening action, its correlation
with the target, and the final distance to the target.

The action gap (`--gap-states`, 8 by default): at flight states the actor reached, the
critic's Q(s, a) and the one-step reward r(s, a) (the env re-played from that state with
each a, the same physics) over 21 actions in [-1, 1]: their ranges (max - min), the
argmax of each, and whether the two argmaxes agree to within one grid step. A critic that
learnt Q for a potential-shaped reward shows no attitude credit as a difference between
actions; a per-decision cost puts it back. Each state is taken with the target of the
episode it came from. With `--gap-returns` each of those actions is also played out, the
deterministic actor deciding from the next decision on, and its discounted return set
beside Q(s, a): whether the critic's landscape over actions is the one its actor earns.

Writes one JSON (atomically) and prints a summary.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from statistics import NormalDist

import numpy as np
import torch
from gymnasium.vector import AutoresetMode

import hoprover_env  # noqa: F401  (registers the ids)
from hoprover_env.agents.policies import load_sb3
from hoprover_env.core.params import RoverParams
from hoprover_env.envs.registry import env_class, task, vector_env_class
from hoprover_env.evaluation.episodes import seeded_targets
from hoprover_env.tasks.config import TRAINING_STARTS
from hoprover_env.util.files import atomic_write

REST, FLIGHT = 5, 0
GROUPS = {"rest": (REST,), "contact": (1, 2, 3, 4, 6), "flight": (FLIGHT,)}
GRID = np.linspace(-1.0, 1.0, 21)
SATURATED = 5.0  # |pre-tanh mean| past which the actor's action hardly moves


def env_arguments(policy) -> dict:
    """The env arguments the policy was trained with over its id's own, less the
    training-only start distribution (every episode here starts as the contest's)."""
    kw = {**task(policy.env_id).kwargs, **policy.env_kwargs}
    for name in TRAINING_STARTS:
        kw.pop(name, None)
    kw.pop("target_x", None)
    return kw


def gaussian_actor(policy, obs: np.ndarray):
    """Per env: the squashed-Gaussian actor's pre-tanh mean and standard deviation, or
    None for an actor of another kind (TD3's; gSDE, whose std depends on the features)."""
    actor = getattr(policy.model, "actor", None)
    if (
        actor is None
        or not hasattr(actor, "get_action_dist_params")
        or getattr(actor, "use_sde", False)
    ):
        return None
    o = torch.as_tensor(policy.normalize(obs), dtype=torch.float32)
    with torch.no_grad():
        mean, log_std, _ = actor.get_action_dist_params(o)
    return mean[:, 0].numpy(), log_std.exp()[:, 0].numpy()


def exploring_spread(policy, obs: np.ndarray) -> np.ndarray:
    """Per env: the exploring action's spread around the actor's action (module docstring);
    NaN for a learner without exploration noise of these kinds."""
    # TD3's Gaussian action noise; SB3 wraps it in a VectorizedActionNoise for several envs
    noise = getattr(policy.model, "action_noise", None)
    noise = getattr(noise, "base_noise", noise)
    if noise is not None and hasattr(noise, "_sigma"):
        return np.full(len(obs), float(np.ravel(noise._sigma)[0]))
    gaussian = gaussian_actor(policy, obs)
    if gaussian is None:
        return np.full(len(obs), np.nan)
    mu, sd = gaussian
    return sd * (1.0 - np.tanh(mu) ** 2)


def pre_tanh_mean(policy, obs: np.ndarray) -> np.ndarray:
    """Per env: the actor's pre-tanh mean (NaN for an actor that has none)."""
    gaussian = gaussian_actor(policy, obs)
    return np.full(len(obs), np.nan) if gaussian is None else gaussian[0]


def tip_probability(action: np.ndarray, spread: np.ndarray, tip: float) -> np.ndarray:
    """P(|a + spread z| > tip), z standard normal: how often exploring tips a resting rover."""
    cdf = np.vectorize(NormalDist().cdf)
    safe = np.where(spread > 0, spread, np.nan)
    inside = cdf((tip - action) / safe) - cdf((-tip - action) / safe)
    return np.where(spread > 0, 1.0 - inside, (np.abs(action) > tip).astype(float))


def play(policy, targets: np.ndarray, seed: int) -> dict:
    """The deterministic actor's episodes side by side, every decision recorded."""
    n = len(targets)
    venv = vector_env_class(policy.env_id)(
        n, autoreset_mode=AutoresetMode.SAME_STEP, info_level="full", **env_arguments(policy)
    )
    obs, info = venv.reset(seed=seed, options={"target_x": targets})
    policy.reset(n)
    modes, acts, omegas, states, spreads, means = [], [], [], [], [], []
    state_episode: list[int] = []  # the episode each flight state came from
    open_ = np.ones(n, bool)
    first = np.full(n, np.nan)
    out = {k: np.zeros(n, bool) for k in ("broken", "success", "ended_in_flight")}
    last_mode = np.full(n, -1)  # the contact state of each episode's latest decision
    run = np.zeros(n, int)  # decisions in the current flight
    longest = np.zeros(n, int)  # each episode's longest flight
    flights: list[int] = []  # each finished flight's decisions
    final = np.full(n, np.nan)
    breaks: list[int] = []  # the contact state of the decision before each break
    while open_.any():
        a = np.asarray(policy.act(obs, venv), dtype=np.float32)
        spread = exploring_spread(policy, obs)
        mu = pre_tanh_mean(policy, obs)
        mode = np.asarray(info["state"]).copy()
        rs = np.asarray(info["rover_state"]).copy()
        last_mode[open_] = mode[open_]
        for i in np.flatnonzero(open_):
            modes.append(mode[i])
            acts.append(float(a[i, 0]))
            spreads.append(float(spread[i]))
            means.append(float(mu[i]))
            omegas.append(rs[i, 5])
            if mode[i] == FLIGHT:
                states.append(rs[i])
                state_episode.append(int(i))
                run[i] += 1
                longest[i] = max(longest[i], run[i])
            elif run[i]:
                flights.append(int(run[i]))
                run[i] = 0
            if math.isnan(first[i]):
                first[i] = a[i, 0]
        a[~open_] = 0.0
        obs, _, term, trunc, info = venv.step(a)
        ended = open_ & (np.asarray(term) | np.asarray(trunc))
        if ended.any():
            fin = info["final_info"]
            for i in np.flatnonzero(ended):
                out["broken"][i] = bool(fin["broken"][i])
                if out["broken"][i]:
                    breaks.append(int(last_mode[i]))
                out["success"][i] = bool(fin["is_success"][i])
                out["ended_in_flight"][i] = int(fin["state"][i]) == FLIGHT
                final[i] = float(fin["rover_state"][i][0]) - targets[i]
        open_ &= ~ended
    venv.close()
    return {
        "flights": np.asarray(flights + [int(r) for r in run if r]),
        "longest": longest,
        "mode": np.asarray(modes),
        "action": np.asarray(acts),
        "spread": np.asarray(spreads),
        "pre_tanh_mean": np.asarray(means),
        "omega": np.asarray(omegas),
        "flight_states": np.asarray(states),
        "flight_state_episode": np.asarray(state_episode, int),
        "opening": first,
        "final": final,
        "breaks": np.asarray(breaks, int),
        **out,
    }


def by_side(run: dict, targets: np.ndarray) -> dict:
    """Episodes, successes and the median opening for the targets left (x* < 0) and right
    of the start: the task is symmetric, so a policy that succeeds on one side only has
    learnt one of its two openings."""
    rows = {}
    for name, sel in (("left", targets < 0), ("right", targets >= 0)):
        rows[name] = {
            "episodes": int(sel.sum()),
            "success": int(run["success"][sel].sum()),
            "median_opening": float(np.median(run["opening"][sel])) if sel.any() else float("nan"),
        }
    return rows


def control_dt(policy) -> float:
    """The policy's control period [s]."""
    return float(env_arguments(policy).get("control_dt", 0.5))


def tipping_action(policy) -> float:
    """|a| whose torque equals m g r under the policy's action map (linear or cubic)."""
    p = RoverParams()
    frac = p.mass * p.gravity * p.half_width / p.torque_max
    scale = policy.env_kwargs.get("action_scale", 1.0)
    if policy.env_kwargs.get("action_map", "linear") == "cubic":
        return (frac / scale) ** (1.0 / 3.0)
    return frac / scale


def abs_tilt_deg(theta: np.ndarray) -> np.ndarray:
    """|theta| wrapped to [0, 180] degrees: how far from upright."""
    return np.abs(np.degrees(np.angle(np.exp(1j * np.asarray(theta)))))


def per_state(run: dict, tip: float) -> dict:
    rows = {}
    for name, codes in GROUPS.items():
        sel = np.isin(run["mode"], codes)
        a, w = run["action"][sel], run["omega"][sel]
        row: dict[str, float] = {"decisions": int(sel.sum())}
        if sel.any():
            row["median_abs_action"] = float(np.median(np.abs(a)))
            row["tipping_share"] = float(np.mean(np.abs(a) > tip))
            spread = run["spread"][sel]
            if np.isfinite(spread).all():
                row["median_exploring_spread"] = float(np.median(spread))
                row["exploring_tip_probability"] = float(np.mean(tip_probability(a, spread, tip)))
            mu = run["pre_tanh_mean"][sel]
            if np.isfinite(mu).all():
                row["median_abs_pre_tanh_mean"] = float(np.median(np.abs(mu)))
                row["saturated_share"] = float(np.mean(np.abs(mu) > SATURATED))
        if name == "flight" and sel.sum() > 2:
            row["median_abs_omega"] = float(np.median(np.abs(w)))
            # how far from upright it flies
            tilt = abs_tilt_deg(run["flight_states"][:, 2])
            row["p90_abs_theta_deg"] = float(np.quantile(tilt, 0.9))
            row["corr_action_minus_omega"] = (
                float(np.corrcoef(a, -w)[0, 1]) if a.std() > 0 and w.std() > 0 else float("nan")
            )
        rows[name] = row
    return rows


def critic_tensor(model, obs: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
    """The critic's value of each (observation, action) row, differentiable: the minimum
    over SAC's and TD3's twin critics, the mean over TQC's quantiles."""
    q = model.critic(obs, actions)
    if isinstance(q, torch.Tensor):
        return q.mean(dim=(1, 2))
    return torch.min(torch.cat(q, dim=1), dim=1).values


def critic_value(model, obs: torch.Tensor, actions: torch.Tensor) -> np.ndarray:
    """critic_tensor's values as an array."""
    with torch.no_grad():
        return critic_tensor(model, obs, actions).numpy()


def action_returns(policy, x0: np.ndarray, target: float) -> np.ndarray:
    """The discounted return of each GRID action taken at flight state x0 and followed by
    the deterministic actor to the episode's end: what the critic's Q(x0, a) estimates. A
    cut by the time limit is bootstrapped with the critic's value there, as the learner
    does (the clock restarts at x0, so the cut comes 600 s later than in the episode)."""
    model, n = policy.model, len(GRID)
    venv = vector_env_class(policy.env_id)(
        n, autoreset_mode=AutoresetMode.SAME_STEP, **env_arguments(policy)
    )
    obs, _ = venv.reset(seed=0, options={"target_x": target, "initial_state": x0})
    policy.reset(n)
    a = GRID[:, None].astype(np.float32)
    ret, discount = np.zeros(n), np.ones(n)
    open_ = np.ones(n, bool)
    while open_.any():
        a[~open_] = 0.0
        obs, rew, term, trunc, info = venv.step(a)
        ret[open_] += discount[open_] * np.asarray(rew)[open_]
        discount[open_] *= model.gamma
        cut = open_ & np.asarray(trunc) & ~np.asarray(term)
        if cut.any():
            last = np.stack([info["final_obs"][i] for i in np.flatnonzero(cut)])
            tail_obs = policy.normalize(last)
            tail_act, _ = model.predict(tail_obs, deterministic=True)
            ret[cut] += discount[cut] * critic_value(
                model,
                torch.as_tensor(tail_obs, dtype=torch.float32),
                torch.as_tensor(tail_act, dtype=torch.float32),
            )
        open_ &= ~(np.asarray(term) | np.asarray(trunc))
        a = np.asarray(policy.act(obs, venv), dtype=np.float32)
    venv.close()
    return ret


def action_gap(
    policy, run: dict, targets, k: int, rng: np.random.Generator, returns: bool = False
) -> list[dict]:
    """Critic and one-step reward over GRID at k flight states, each with the target of
    the episode it came from; with `returns`, also the return each action earns."""
    model = policy.model
    states = run["flight_states"]
    if len(states) == 0:
        return []
    pick = rng.choice(len(states), size=min(k, len(states)), replace=False)
    env_kw = env_arguments(policy)
    rows = []
    for j in pick:
        x0 = states[j]
        target = float(targets[run["flight_state_episode"][j]])
        env = env_class(policy.env_id)(target_x=target, **env_kw)
        obs, _ = env.reset(seed=0, options={"initial_state": x0})
        r = []
        for a in GRID:
            env.reset(seed=0, options={"initial_state": x0})
            _, rew, *_ = env.step(np.array([a], dtype=np.float32))
            r.append(float(rew))
        env.close()
        o = torch.as_tensor(policy.normalize(obs[None]), dtype=torch.float32).repeat(len(GRID), 1)
        act = torch.as_tensor(GRID[:, None], dtype=torch.float32)
        q = critic_value(model, o, act)
        row: dict[str, object] = {
            "omega": float(x0[5]),
            "theta": float(x0[2]),
            "reward_range": float(np.ptp(r)),
            "q_range": float(np.ptp(q)),
            "reward_argmax": float(GRID[int(np.argmax(r))]),
            "q_argmax": float(GRID[int(np.argmax(q))]),
            "agree": bool(abs(np.argmax(r) - np.argmax(q)) <= 1),
        }
        if returns:
            g = action_returns(policy, x0, target)
            row.update(
                return_range=float(np.ptp(g)),
                return_argmax=float(GRID[int(np.argmax(g))]),
                q_agrees_with_return=bool(abs(np.argmax(g) - np.argmax(q)) <= 1),
                q_minus_return=[float(v) for v in q - g],
                q=[float(v) for v in q],
                returns=[float(v) for v in g],
            )
        rows.append(row)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", type=Path, required=True, help="an SB3 .zip saved by train.py")
    ap.add_argument("--episodes", type=int, default=40)
    ap.add_argument("--gap-states", type=int, default=8)
    ap.add_argument(
        "--gap-returns",
        action="store_true",
        help="also play each grid action out with the actor: the return the critic estimates",
    )
    ap.add_argument("--seed", type=int, default=2015, help="the targets' seed")
    ap.add_argument("--out", type=Path, required=True, help="the JSON to write")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    policy = load_sb3(args.model)
    targets = seeded_targets(args.episodes, args.seed)
    run = play(policy, targets, args.seed)
    opening_corr = (
        float(np.corrcoef(run["opening"], targets)[0, 1])
        if np.std(run["opening"]) > 0
        else float("nan")
    )
    report = {
        "model": str(args.model),
        "env_id": policy.env_id,
        "episodes": args.episodes,
        "per_state": per_state(run, tipping_action(policy)),
        "broken": int(run["broken"].sum()),
        "broken_from": {
            name: int(np.isin(run["breaks"], codes).sum()) for name, codes in GROUPS.items()
        },
        "success": int(run["success"].sum()),
        "median_final_distance_m": float(np.median(np.abs(run["final"]))),
        "ended_in_flight": int(run["ended_in_flight"].sum()),
        "median_flight_s": float(np.median(run["flights"]) * control_dt(policy))
        if len(run["flights"])
        else float("nan"),
        "median_longest_flight_s": float(np.median(run["longest"]) * control_dt(policy)),
        "median_abs_opening": float(np.median(np.abs(run["opening"]))),
        "corr_opening_target": opening_corr,
        "by_side": by_side(run, targets),
        "action_gap": action_gap(
            policy,
            run,
            targets,
            args.gap_states,
            np.random.default_rng(args.seed),
            returns=args.gap_returns,
        ),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out, json.dumps(report, indent=1) + "\n")
    print(json.dumps({k: v for k, v in report.items() if k != "action_gap"}, indent=1))
    for g in report["action_gap"]:
        print(
            f"  flight state omega {g['omega']:+.2f}: reward range {g['reward_range']:.3f}, "
            f"Q range {g['q_range']:.3f}, argmax r {g['reward_argmax']:+.1f} Q "
            f"{g['q_argmax']:+.1f}"
            + (
                f", return range {g['return_range']:.3f} argmax {g['return_argmax']:+.1f}"
                if "return_range" in g
                else ""
            )
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
