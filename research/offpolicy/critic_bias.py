"""How far a trained off-policy critic's value is from the return its policy earns, per
contact state and, in flight, per attitude: does the critic over-rate the states its
actor drifts to?

    python -m research.offpolicy.critic_bias --model runs/sac/best_model.zip \\
        --episodes 40 --out benchmarks/results/offpolicy/critic_bias_sac.json

Loads an SB3 SAC or TQC model saved by train.py and plays `--episodes` episodes from
rest (seeded targets in [-1, 1] m) with the policy the critic evaluates: the actor's
samples, not its mean. At every decision it takes the critic's value of the state and
the action taken, as the learner's own target reads it (SAC: the minimum over its
critics; TQC: the mean of the quantiles left after dropping the top ones), and the soft
return that decision actually earned: the rewards from there on, discounted with the
learner's gamma, plus the entropy bonus -alpha log pi of every later action (the soft
value SAC and TQC learn). An episode cut by the time limit is bootstrapped with the
critic's soft value at its last state, as the learner bootstraps it; a termination
(success, or a break) ends the sum.

Reported per contact state (rest, ground contact, flight), and in flight for upright
(|theta| < 30 degrees) and tilted (>= 30 degrees) states apart: the decisions, the median
return, and the median and mean of value - return (positive: over-estimation). A critic
that rates tilted flight above what it earns pulls its actor there.

Writes one JSON (atomically) and prints it.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch
from gymnasium.vector import AutoresetMode

import hoprover_env  # noqa: F401  (registers the ids)
from hoprover_env.agents.policies import load_sb3
from hoprover_env.envs.registry import vector_env_class
from hoprover_env.evaluation.episodes import seeded_targets
from hoprover_env.util.files import atomic_write
from research.offpolicy.actors import GROUPS, abs_tilt_deg, env_arguments

TILTED_DEG = 30.0


def _value(model, obs: torch.Tensor, act: torch.Tensor) -> torch.Tensor:
    """The critic's value as the learner's target reads it."""
    q = model.critic(obs, act)
    if isinstance(q, torch.Tensor):  # TQC: (batch, critics, quantiles)
        atoms = torch.sort(q.reshape(q.shape[0], -1), dim=1).values
        keep = atoms.shape[1] - model.top_quantiles_to_drop_per_net * q.shape[1]
        return atoms[:, :keep].mean(dim=1)
    return torch.min(torch.cat(q, dim=1), dim=1).values


def _sample(model, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Actions sampled from the actor, their log-probabilities and the critic's value."""
    o = torch.as_tensor(obs, dtype=torch.float32)
    with torch.no_grad():
        a, logp = model.actor.action_log_prob(o)
        q = _value(model, o, a)
    return a.numpy(), logp.numpy(), q.numpy()


def play(policy, targets: np.ndarray, seed: int) -> dict:
    """The sampling actor's episodes side by side: per decision the critic's value, the
    reward, the action's log-probability, the contact state and theta; per episode the
    soft value that bootstraps a cut (0 where the episode ended)."""
    model, n = policy.model, len(targets)
    torch.manual_seed(seed)
    venv = vector_env_class(policy.env_id)(
        n, autoreset_mode=AutoresetMode.SAME_STEP, info_level="full", **env_arguments(policy)
    )
    obs, info = venv.reset(seed=seed, options={"target_x": targets})
    steps: list[list[tuple]] = [[] for _ in range(n)]  # (value, reward, logp, mode, theta)
    tail = np.zeros(n)  # the soft value at a truncated episode's last state; 0 if it ended
    open_ = np.ones(n, bool)
    while open_.any():
        a, logp, q = _sample(model, policy.normalize(obs))
        mode = np.asarray(info["state"]).copy()
        theta = np.asarray(info["rover_state"])[:, 2].copy()
        a[~open_] = 0.0
        obs, rew, term, trunc, info = venv.step(a.astype(np.float32))
        for i in np.flatnonzero(open_):
            steps[i].append((q[i], float(rew[i]), logp[i], int(mode[i]), theta[i]))
        cut = open_ & np.asarray(trunc) & ~np.asarray(term)
        if cut.any():
            last = np.stack([info["final_obs"][i] for i in np.flatnonzero(cut)])
            _, logp_t, q_t = _sample(model, policy.normalize(last))
            tail[cut] = q_t - entropy_coefficient(model) * logp_t
        open_ &= ~(np.asarray(term) | np.asarray(trunc))
    venv.close()
    return {"steps": steps, "tail": tail}


def entropy_coefficient(model) -> float:
    """alpha: learnt (log_ent_coef) or fixed (ent_coef_tensor)."""
    if getattr(model, "log_ent_coef", None) is not None:
        return float(torch.exp(model.log_ent_coef.detach()))
    return float(model.ent_coef_tensor)


def soft_returns(steps: list[tuple], tail: float, gamma: float, alpha: float) -> np.ndarray:
    """Each decision's soft return, summed backwards from the episode's end."""
    g = np.zeros(len(steps))
    after = tail  # the soft value of what follows the decision at hand
    for t in range(len(steps) - 1, -1, -1):
        g[t] = steps[t][1] + gamma * after
        after = g[t] - alpha * steps[t][2]  # the bonus of this decision's own action
    return g


def report(policy, run: dict) -> dict:
    model = policy.model
    alpha = entropy_coefficient(model)
    value, ret, mode, theta = [], [], [], []
    for steps, tail in zip(run["steps"], run["tail"]):
        ret.append(soft_returns(steps, tail, model.gamma, alpha))
        value.append([s[0] for s in steps])
        mode.append([s[3] for s in steps])
        theta.append([s[4] for s in steps])
    v, g = np.concatenate(value), np.concatenate(ret)
    m, th = np.concatenate(mode), np.concatenate(theta)
    tilt = abs_tilt_deg(th)
    groups = {name: np.isin(m, codes) for name, codes in GROUPS.items()}
    groups["flight_upright"] = groups["flight"] & (tilt < TILTED_DEG)
    groups["flight_tilted"] = groups["flight"] & (tilt >= TILTED_DEG)
    rows = {}
    for name, sel in groups.items():
        rows[name] = {"decisions": int(sel.sum())}
        if sel.any():
            rows[name].update(
                median_return=float(np.median(g[sel])),
                median_bias=float(np.median(v[sel] - g[sel])),
                mean_bias=float(np.mean(v[sel] - g[sel])),
            )
    return {"alpha": alpha, "gamma": float(model.gamma), "per_state": rows}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", type=Path, required=True, help="an SB3 .zip saved by train.py")
    ap.add_argument("--episodes", type=int, default=40)
    ap.add_argument("--seed", type=int, default=2015, help="the targets' seed")
    ap.add_argument("--out", type=Path, required=True, help="the JSON to write")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    policy = load_sb3(args.model)
    if not hasattr(policy.model.actor, "action_log_prob"):
        ap.error(f"{args.model}: not a SAC or TQC model (its actor has no log-probability)")
    run = play(policy, seeded_targets(args.episodes, args.seed), args.seed)
    out = {"model": str(args.model), "episodes": args.episodes, **report(policy, run)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out, json.dumps(out, indent=1) + "\n")
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
