"""Why an off-policy learner (SAC, TD3, TQC, CrossQ) does or does not learn HopRover: train
from a config and, every `--every` steps, hold the learner still and measure.

    python -m research.offpolicy.diagnose --config configs/sac.yaml --steps 150000 \\
        --every 25000 --out runs/diagnose/sac

At each checkpoint, 32 episodes are played with the behaviour the learner explores with
(SAC: a sample of its squashed Gaussian; TD3: its actor plus its Gaussian noise) and
32 with its deterministic actor on the train.py validation targets. Written as one CSV row:

- `q_pred`: the critics' value of the first state and action of each exploring episode
  (the minimum over critics, as the learner's target uses; the mean for CrossQ/TQC's
  quantiles), against `q_mc`: the discounted return that episode actually earned from
  there (SAC: with the entropy bonus the soft value counts). An episode cut by the time
  limit is bootstrapped with the critic at its last state, and `truncated` says how many.
  q_pred far above q_mc is over-estimation; growing without bound, divergence.
- `reward_min`, `reward_max`, `return_mean`: the scale the critic must fit.
- `tip_frac_rest`: of the exploring decisions taken at rest (contact state F), the
  fraction whose torque exceeds the tipping torque m g r (the smallest torque that moves
  a rover at rest): what exploration does to a rover that should keep still. Flight
  decisions outnumber rest decisions by two orders of magnitude and a torque in flight
  tips nothing, so only decisions at rest count; `decisions_rest`, `decisions_contact`
  and `decisions_flight` say how the exploring decisions split by contact state (ground
  contact: pivoting or sliding, states B-E and G).
- `explore_success`, `explore_broken`, `eval_success`, `eval_broken`, `eval_median_ttrtp`.
- `ent_coef` (SAC/TQC/CrossQ) and `obs_std_max`/`obs_std_min` of the observation
  normalisation (statistics that keep moving while the replay buffer keeps old samples).

Writes OUT/diagnosis.csv (atomically, after every checkpoint) and the training's own
evaluations through nothing else: this is a measurement, not a training run to keep.
"""

from __future__ import annotations

import argparse
import csv
import importlib
import io
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import torch

from hoprover_env.agents.policies import SB3Policy, torque_to_action
from hoprover_env.core.params import RoverParams
from hoprover_env.envs.registry import task
from hoprover_env.envs.sb3 import HopRoverSB3VecEnv
from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize
from hoprover_env.tasks import observation
from hoprover_env.training.sb3_agents import env_kwargs, load_config, make_agent
from hoprover_env.training.train import build_env
from hoprover_env.util.files import atomic_write

REST, FLIGHT = 5, 0  # contact state codes F and A
FIELDS = [
    "timesteps",
    "wall_s",
    "q_pred",
    "q_mc",
    "q_bias",
    "truncated",
    "reward_min",
    "reward_max",
    "return_mean",
    "tip_frac_rest",
    "decisions_rest",
    "decisions_contact",
    "decisions_flight",
    "explore_success",
    "explore_broken",
    "eval_success",
    "eval_broken",
    "eval_median_ttrtp",
    "ent_coef",
    "obs_std_min",
    "obs_std_max",
]


def tipping_action(cfg: dict) -> float:
    """The smallest |action| whose torque tips a rover at rest (m g r / T_max under the
    config's action map and scale)."""
    p = RoverParams()
    return torque_to_action(
        p.mass * p.gravity * p.half_width, p, SimpleNamespace(**env_kwargs(cfg))
    )


def mode_slot(env_id: str) -> int:
    """Where the one-hot contact state starts in the id's observation (its task module's
    OBS_MODE, or the torque task's)."""
    module = importlib.import_module(task(env_id).module)
    return int(getattr(module, "OBS_MODE", observation.OBS_MODE))


def critic_value(model, obs: torch.Tensor, act: torch.Tensor) -> np.ndarray:
    """The value the learner's target uses: min over the critics (SAC, TD3, CrossQ), the
    mean over the kept quantiles for TQC."""
    with torch.no_grad():
        q = model.critic(obs, act)
        if isinstance(q, torch.Tensor):  # TQC: (batch, critics, quantiles)
            return q.mean(dim=(1, 2)).numpy()
        return torch.min(torch.cat(q, dim=1), dim=1).values.numpy()


def explore_action(model, obs: torch.Tensor, rng: np.random.Generator):
    """The exploring action and, for the soft learners, -ent_coef * log pi(a|s)."""
    with torch.no_grad():
        if hasattr(model, "log_ent_coef") or hasattr(model, "ent_coef_tensor"):
            act, logp = model.actor.action_log_prob(obs)
            alpha = float(ent_coef(model))
            return act, (-alpha * logp).numpy()
        act = model.actor(obs)
        noise = getattr(model.action_noise, "base_noise", model.action_noise)
        sigma = float(np.ravel(noise._sigma)[0]) if noise is not None else 0.1
        act = (act + torch.as_tensor(rng.normal(0, sigma, act.shape), dtype=act.dtype)).clamp(-1, 1)
        return act, np.zeros(len(obs))


def ent_coef(model) -> float:
    if getattr(model, "log_ent_coef", None) is not None:
        return float(torch.exp(model.log_ent_coef.detach()).item())
    coef = getattr(model, "ent_coef_tensor", None)
    return float(coef.item()) if coef is not None else float("nan")


def explore(model, venv, cfg, episodes: int, seed: int) -> dict:
    """`episodes` exploring episodes side by side, from their first state to their end."""
    env = HopRoverSB3VecEnv(episodes, seed=seed, env_id=cfg["env_id"], **env_kwargs(cfg))
    gamma, rng = model.gamma, np.random.default_rng(seed)
    obs = env.reset()
    rewards, bonus = [[] for _ in range(episodes)], [[] for _ in range(episodes)]
    open_ = np.ones(episodes, bool)
    q0 = tail = None
    trunc = np.zeros(episodes, bool)
    success, broken = np.zeros(episodes, bool), np.zeros(episodes, bool)
    counts = {"rest": 0, "contact": 0, "flight": 0}
    n_tip = 0
    mode = np.full(episodes, REST)  # every episode starts upright at rest
    slot = mode_slot(cfg["env_id"])
    tip = tipping_action(cfg)
    while open_.any():
        o = torch.as_tensor(venv.normalize_obs(obs), dtype=torch.float32)
        act, ent = explore_action(model, o, rng)
        if q0 is None:
            q0 = critic_value(model, o, act)
            tail = np.zeros(episodes)
        a = act.numpy()
        at_rest, flying = open_ & (mode == REST), open_ & (mode == FLIGHT)
        counts["rest"] += int(at_rest.sum())
        counts["flight"] += int(flying.sum())
        counts["contact"] += int((open_ & ~at_rest & ~flying).sum())
        n_tip += int((np.abs(a[:, 0]) > tip)[at_rest].sum())
        for i in np.flatnonzero(open_):
            bonus[i].append(ent[i])
        obs, rew, done, infos = env.step(a)
        mode = np.argmax(obs[:, slot : slot + 7], axis=1)  # the next decision's state
        for i in np.flatnonzero(open_ & done):
            info = infos[i]
            success[i], broken[i] = bool(info.get("is_success")), bool(info.get("broken"))
            if info.get("TimeLimit.truncated", False):
                trunc[i] = True
                last = torch.as_tensor(
                    venv.normalize_obs(info["terminal_observation"][None]), dtype=torch.float32
                )
                a_last, _ = explore_action(model, last, rng)
                tail[i] = critic_value(model, last, a_last)[0]
        for i in np.flatnonzero(open_):
            rewards[i].append(float(rew[i]))
        open_ &= ~done
    env.close()
    q_mc = np.empty(episodes)
    for i in range(episodes):
        r = np.asarray(rewards[i]) + np.concatenate([[0.0], bonus[i][1:]]) * gamma
        disc = gamma ** np.arange(len(r))
        q_mc[i] = float((disc * r).sum() + gamma ** len(r) * tail[i])
    allr = np.concatenate([np.asarray(r) for r in rewards])
    return {
        "q_pred": float(q0.mean()),
        "q_mc": float(q_mc.mean()),
        "q_bias": float((q0 - q_mc).mean()),
        "truncated": int(trunc.sum()),
        "reward_min": float(allr.min()),
        "reward_max": float(allr.max()),
        "return_mean": float(np.mean([np.sum(r) for r in rewards])),
        "tip_frac_rest": n_tip / max(counts["rest"], 1),
        **{f"decisions_{k}": v for k, v in counts.items()},
        "explore_success": float(success.mean()),
        "explore_broken": int(broken.sum()),
    }


def measure(model, venv, cfg, targets, t0: float) -> dict:
    import copy

    row = {"timesteps": int(model.num_timesteps), "wall_s": round(time.perf_counter() - t0, 1)}
    row.update(explore(model, venv, cfg, 32, seed=1000 + int(model.num_timesteps)))
    policy = SB3Policy(
        model,
        copy.deepcopy(venv.obs_rms),
        venv.clip_obs,
        epsilon=venv.epsilon,
        env_kwargs=env_kwargs(cfg),
        env_id=cfg["env_id"],
    )
    res = summarize(run_episodes(policy, targets, env_kwargs(cfg)))
    std = np.sqrt(venv.obs_rms.var)
    row.update(
        eval_success=res["success_rate"],
        eval_broken=res["broken"],
        eval_median_ttrtp=res["median_ttrtp"],
        ent_coef=ent_coef(model),
        obs_std_min=float(std.min()),
        obs_std_max=float(std.max()),
    )
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--steps", type=int, required=True)
    ap.add_argument("--every", type=int, default=25_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", required=True)
    ap.add_argument("--torch-threads", type=int, default=1)
    args = ap.parse_args(argv)
    torch.set_num_threads(args.torch_threads)
    cfg = load_config(args.config, {"seed": args.seed, "timesteps": args.steps})
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    venv = build_env(cfg)
    model = make_agent(cfg, venv)
    targets = seeded_targets(32, cfg["evaluation"]["seed"])
    rows, t0 = [], time.perf_counter()
    while True:
        rows.append(measure(model, venv, cfg, targets, t0))
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=FIELDS)
        w.writeheader()
        w.writerows(rows)
        atomic_write(out / "diagnosis.csv", buf.getvalue())
        print(
            ", ".join(
                f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in rows[-1].items()
            ),
            file=sys.stderr,
            flush=True,
        )
        if model.num_timesteps >= args.steps:
            return 0
        model.learn(args.every, reset_num_timesteps=False)


if __name__ == "__main__":
    raise SystemExit(main())
