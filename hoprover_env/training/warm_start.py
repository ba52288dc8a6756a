"""Behaviour cloning: warm-start a PPO policy from an expert controller.

The expert (by default the scripted hopper) is run in the batched env on random
targets; its observations and actions train the PPO actor's mean by least squares, and
the discounted returns of those episodes (normalised the way VecNormalize will
normalise rewards) train the critic, so that PPO's first updates start from a
sensible advantage estimate instead of undoing the clone.

Plain cloning compounds small errors (a launch torque held for 50 steps drifts), so the
demonstrations are collected with noise injected into the executed actions (DART,
Laskey et al. 2017) while the labels stay the expert's, and DAgger rounds (Ross et al.
2011) let the learner drive while the expert, shadowing it, labels the states the
learner actually reaches.
"""

from __future__ import annotations

import numpy as np
import torch
from gymnasium.vector import AutoresetMode

from hoprover_env.agents.planning import UPPER
from hoprover_env.envs.vector_env import HopRoverVectorEnv
from hoprover_env.tasks.observation import OBS_DIM, OBS_MODE, OBS_TIME


def share_statistics(policy, vecnorm) -> None:
    """Hand `vecnorm`'s observation statistics to each of `policy`'s features extractors
    that asks for them (a `use_statistics(mean, std)` method, std as VecNormalize
    divides by: sqrt(var + epsilon)), such as an extractor that recovers the raw
    observation from the normalised one."""
    mean = torch.as_tensor(np.asarray(vecnorm.obs_rms.mean), dtype=torch.float32)
    std = torch.as_tensor(
        np.sqrt(np.asarray(vecnorm.obs_rms.var) + vecnorm.epsilon), dtype=torch.float32
    )
    for name in ("features_extractor", "pi_features_extractor", "vf_features_extractor"):
        ext = getattr(policy, name, None)
        if hasattr(ext, "use_statistics"):
            ext.use_statistics(mean, std)


def collect(
    expert,
    env_kwargs: dict,
    episodes: int,
    seed: int,
    gamma: float,
    batch: int = 256,
    executor=None,
    noise: float = 0.0,
    log=None,
    targets=None,
):
    """(obs, expert actions, discounted returns) of `episodes` episodes. The actions
    executed are the expert's plus N(0, noise^2), or the `executor`'s (DAgger); the
    labels are always the expert's. `targets` (one per episode) replaces the uniform
    draw from the env's `target_range`. `log(message)` after each batch of episodes."""
    kwargs = {**env_kwargs, **getattr(expert, "env_kwargs", {})}
    kwargs.pop("target_x", None)
    cfg_lo, cfg_hi = kwargs.get("target_range", (-1.0, 1.0))
    if targets is not None:
        targets = np.asarray(targets, dtype=np.float64)
        if len(targets) != episodes:
            raise ValueError(f"targets has {len(targets)} entries for {episodes} episodes")
    rng = np.random.default_rng(seed)
    all_obs, all_act, all_ret = [], [], []
    for start in range(0, episodes, batch):
        n = min(batch, episodes - start)
        venv = HopRoverVectorEnv(n, autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)
        reset_seed = int(rng.integers(2**31))
        tx = rng.uniform(cfg_lo, cfg_hi, n) if targets is None else targets[start : start + n]
        obs, _ = venv.reset(seed=reset_seed, options={"target_x": tx})
        expert.reset(n)
        if hasattr(expert, "shadowing"):  # mpc: replan from the flights a learner makes
            expert.shadowing = executor is not None
        if executor is not None:
            executor.reset(n)
        active = np.ones(n, dtype=bool)
        traj_obs, traj_act, traj_rew = (
            [[] for _ in range(n)],
            [[] for _ in range(n)],
            [[] for _ in range(n)],
        )
        while active.any():
            act = expert.act(obs, venv)
            act[~active] = 0.0
            for i in np.flatnonzero(active):
                traj_obs[i].append(obs[i].copy())
                traj_act[i].append(act[i].copy())
            if executor is not None:
                run = executor.act(obs, venv)
            else:
                run = act + noise * rng.standard_normal(act.shape) if noise > 0 else act
            run = np.clip(run, -1.0, 1.0)
            run[~active] = 0.0
            obs, rew, term, trunc, _ = venv.step(run)
            for i in np.flatnonzero(active):
                traj_rew[i].append(rew[i])
            active &= ~(term | trunc)
        for i in range(n):
            r = np.array(traj_rew[i])
            ret = np.zeros_like(r)
            acc = 0.0
            for k in range(len(r) - 1, -1, -1):
                acc = r[k] + gamma * acc
                ret[k] = acc
            all_obs.extend(traj_obs[i])
            all_act.extend(traj_act[i])
            all_ret.extend(ret)
        if log is not None:
            log(
                f"  {'DAgger' if executor is not None else 'demonstrations'}: "
                f"{start + n}/{episodes} episodes"
            )
    return (
        np.array(all_obs, dtype=np.float32),
        np.array(all_act, dtype=np.float32),
        np.array(all_ret, dtype=np.float64),
    )


def clone(
    model,
    vecnorm,
    obs,
    actions,
    returns,
    epochs: int = 30,
    batch_size: int = 1024,
    learning_rate: float = 1e-3,
    value_epochs: int = 10,
    log_std: float = -2.5,
    seed: int = 0,
    log=print,
    ground_weight: float = 1.0,
    learning_rate_end: float | None = None,
    launch_weight: float | None = None,
    start_weight: float | None = None,
    episode_time: float = 600.0,
    fit_statistics: bool = True,
):
    """Fit the PPO policy to the expert data; set VecNormalize's statistics from it
    (`fit_statistics`; False: normalise with the statistics it has, e.g. those a
    warm-started policy was fitted with).

    `ground_weight` weighs the samples taken out of flight against those in flight (1:
    plain least squares). A planner's flight is an attitude hold, a smooth feedback law
    with large torques that dominates the squared error, while the decisions that set
    where a hop lands are small torques held on the ground (a launch torque 1 % off
    costs up to 3 % of TTRTP; docs/studies/imitation-of-mpc.md), so they
    are weighted up. `launch_weight` (None: `ground_weight`) weighs the ground samples of
    the first `LAUNCH_S` s, where a launch is held, and `start_weight` (None: as the
    launch) the first decision from rest at t = 0, which sets the whole hop: a few
    hundred samples among hundreds of thousands, that a plain fit leaves 4-7 % off.
    `learning_rate_end`: the learning rate decays to it along a cosine
    over all epochs (None: constant)."""
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    rms = vecnorm.obs_rms
    if fit_statistics:
        rms.mean = obs.mean(axis=0).astype(np.float64)
        rms.var = obs.var(axis=0).astype(np.float64) + 1e-8
        rms.count = float(len(obs))
    scale = 1.0
    if vecnorm.norm_reward:
        scale = float(np.sqrt(np.var(returns) + vecnorm.epsilon))
        vecnorm.ret_rms.var = np.array(scale**2)
        vecnorm.ret_rms.mean = np.array(0.0)
        vecnorm.ret_rms.count = float(len(returns))
    share_statistics(model.policy, vecnorm)  # a features layer that undoes them
    x = torch.as_tensor(vecnorm.normalize_obs(obs), dtype=torch.float32)
    y = torch.as_tensor(np.clip(actions, -1.0, 1.0), dtype=torch.float32)
    z = torch.as_tensor(
        np.clip(returns / scale, -vecnorm.clip_reward * 10, vecnorm.clip_reward * 10),
        dtype=torch.float32,
    )
    policy = model.policy
    policy.set_training_mode(True)

    def actor_mean(xb):
        return policy.action_net(
            policy.mlp_extractor.forward_actor(
                policy.extract_features(xb, policy.pi_features_extractor)
            )
        )

    def critic_value(xb):
        return policy.value_net(
            policy.mlp_extractor.forward_critic(
                policy.extract_features(xb, policy.vf_features_extractor)
            )
        ).squeeze(-1)

    actor = list(policy.mlp_extractor.policy_net.parameters()) + list(
        policy.action_net.parameters()
    )
    critic = list(policy.mlp_extractor.value_net.parameters()) + list(policy.value_net.parameters())
    if getattr(policy, "share_features_extractor", True) is False:
        actor += list(policy.pi_features_extractor.parameters())
        critic += list(policy.vf_features_extractor.parameters())
    weight = sample_weights(obs, ground_weight, launch_weight, start_weight, episode_time)
    if weight is not None:
        weight = torch.as_tensor(weight, dtype=torch.float32)
    mse = _fit(
        actor,
        actor_mean,
        x,
        y,
        epochs,
        batch_size,
        learning_rate,
        rng,
        lambda k, m: log(f"  cloning epoch {k}/{epochs}: action MSE {m:.2e}"),
        weight=weight,
        learning_rate_end=learning_rate_end,
    )
    log(f"  behaviour cloning: {epochs} epochs, action MSE {mse:.2e}")
    if value_epochs:
        mse = _fit(
            critic,
            critic_value,
            x,
            z,
            value_epochs,
            batch_size,
            learning_rate,
            rng,
            lambda k, m: log(f"  critic epoch {k}/{value_epochs}: value MSE {m:.3e}"),
        )
        log(f"  critic pre-training: value MSE {mse:.3e} (returns scaled by {scale:.3g})")
    with torch.no_grad():
        policy.log_std.fill_(log_std)
    policy.set_training_mode(False)


LAUNCH_S = float(UPPER[1])  # s: the longest launch window of the plan family


def sample_weights(
    obs,
    ground_weight: float = 1.0,
    launch_weight: float | None = None,
    start_weight: float | None = None,
    episode_time: float = 600.0,
):
    """Per-sample weights of the cloning loss (None: all equal); see `clone`.
    `episode_time` [s] is the env's, which scales the observation's clock."""
    if launch_weight is None:
        launch_weight = ground_weight
    if start_weight is None:
        start_weight = launch_weight
    if ground_weight == launch_weight == start_weight == 1.0:
        return None
    if obs.shape[1] != OBS_DIM:
        raise ValueError(
            f"ground_weight needs the torque task's observation ({OBS_DIM} "
            f"slots), got {obs.shape[1]}"
        )
    ground = obs[:, OBS_MODE] <= 0.5
    t = obs[:, OBS_TIME] * episode_time
    w = np.where(ground, ground_weight, 1.0)
    w[ground & (t < LAUNCH_S)] = launch_weight
    w[ground & (t == 0.0)] = start_weight
    return w


def _fit(
    params,
    forward,
    x,
    y,
    epochs,
    batch_size,
    learning_rate,
    rng,
    progress=None,
    every: float = 10.0,
    weight=None,
    learning_rate_end: float | None = None,
) -> float:
    """Least squares of forward(x) on y by Adam over mini-batches; the last epoch's
    (weighted) MSE. `weight` (one per sample, None: equal) weighs the squared errors;
    `learning_rate_end` ends a cosine decay of the learning rate (None: constant).
    `progress(epoch, mse)` after the first epoch and then at most every `every` seconds
    (an epoch over a large DAgger set takes tens of seconds on one core)."""
    import time

    opt = torch.optim.Adam(params, lr=learning_rate)
    n = len(x)
    sched = None
    if learning_rate_end is not None:
        sched = torch.optim.lr_scheduler.CosineAnnealingLR(
            opt, T_max=epochs * -(-n // batch_size), eta_min=learning_rate_end
        )
    total = 0.0
    last = None
    for epoch in range(1, epochs + 1):
        perm = rng.permutation(n)
        total = 0.0
        for k in range(0, n, batch_size):
            idx = torch.as_tensor(perm[k : k + batch_size])
            err = ((forward(x[idx]) - y[idx]) ** 2).reshape(len(idx), -1).mean(dim=1)
            if weight is None:
                loss = err.mean()
            else:
                loss = (weight[idx] * err).sum() / weight[idx].sum()
            opt.zero_grad()
            loss.backward()
            opt.step()
            if sched is not None:
                sched.step()
            total += loss.item() * len(idx)
        now = time.perf_counter()
        if progress is not None and epoch < epochs and (last is None or now - last >= every):
            progress(epoch, total / max(n, 1))
            last = now
    return total / max(n, 1)
