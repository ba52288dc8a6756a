"""Cloning studies toward a learned policy within 5 % of the best-known plans: collect
expert data once, then fit and judge clones of it in seconds to minutes.

    python -m research.plan_clone.clone_study collect --out runs/clone/demo_a.npz --seed 11 \\
        --episodes 200
    python -m research.plan_clone.clone_study collect --out runs/clone/short.npz --seed 23 \\
        --episodes 200 --target-range -0.35 0.35                      # short hops only
    python -m research.plan_clone.clone_study fit --data runs/clone/demo_a.npz --epochs 100 \\
        --ground-weight 10 --save runs/clone/clone_a.pkl

`collect` runs `hoprover_env.training.warm_start.collect` with the expert (mpc by default) on
HopRover-v0 at `control_dt` 0.5 s with DART noise `--noise` on the executed actions, or,
with `--learner PKL`, lets a saved clone drive while the expert labels (DAgger). `fit`
fits the actor of configs/ppo_mpc.yaml's PPO policy to the collections
(`imitation.clone`: weighted least squares, cosine learning-rate decay), then judges it
on train.py's 100 validation targets (seed 7) and on the level-v1 suite against its
best-known references, with the regret by target distance (|d| < 0.1 m starts in the
band; 0.1-0.32 m are the short hops; beyond, one long hop).
`train.py --config configs/ppo_mpc.yaml` is the one-command pipeline; this driver is
for studying its parts.
"""

from __future__ import annotations

import argparse
import copy
import pickle
import sys
import time

import numpy as np

CONFIG = "configs/ppo_mpc.yaml"
BINS = ((0.0, 0.1), (0.1, 0.32), (0.32, 1.01))


def _model(action_map: str, arch=None, activation: str | None = None, features: str | None = None):
    from hoprover_env.training.sb3_agents import load_config, make_agent
    from hoprover_env.training.train import build_env

    cfg = load_config(CONFIG)
    cfg["n_envs"] = 4
    cfg["env"]["action_map"] = action_map
    if arch:
        cfg["policy"]["net_arch"] = list(arch)
    if activation:
        cfg["policy"]["activation_fn"] = activation
    if features:
        from research.plan_clone.features import EXTRACTOR_PATHS

        cfg["policy"]["features_extractor"] = EXTRACTOR_PATHS[features]
    venv = build_env(cfg)
    return cfg, venv, make_agent(cfg, venv)


def _policy(cfg, venv, model, name="clone"):
    from hoprover_env.agents.policies import SB3Policy
    from hoprover_env.training.sb3_agents import env_kwargs

    return SB3Policy(
        model, copy.deepcopy(venv.obs_rms), venv.clip_obs, name=name, env_kwargs=env_kwargs(cfg)
    )


def _load(path, venv, model, log=None):
    """Weights and statistics of a clone saved by `fit --save`. A clone fitted without
    `--features` loads into one with them: its first layers' weights on the new inputs
    are zero (the same function to start from), and the features get the statistics."""
    import torch

    from research.plan_clone.features import set_statistics

    with open(path, "rb") as f:
        saved = pickle.load(f)
    state = model.policy.state_dict()
    for key, value in saved["policy"].items():
        if (
            key in state
            and state[key].shape != value.shape
            and value.dim() == 2
            and state[key].shape[0] == value.shape[0]
            and state[key].shape[1] > value.shape[1]
        ):
            padded = torch.zeros_like(state[key])
            padded[:, : value.shape[1]] = value
            value = padded
            if log:
                log(
                    f"{key}: zero weights on the {padded.shape[1] - saved['policy'][key].shape[1]}"
                    " new inputs"
                )
        state[key] = value
    model.policy.load_state_dict(state)
    venv.obs_rms.mean, venv.obs_rms.var = saved["mean"], saved["var"]
    set_statistics(model.policy, venv)


def save_clone(path, model, venv) -> None:
    """A clone's weights and observation statistics, as `_load` reads them (written
    atomically)."""
    from hoprover_env.util.files import atomic_write

    atomic_write(
        str(path),
        pickle.dumps(
            {
                "policy": model.policy.state_dict(),
                "mean": venv.obs_rms.mean,
                "var": venv.obs_rms.var,
            }
        ),
    )


def load_clone(
    path, activation: str | None = None, arch=None, name="learner", features: str | None = None
):
    """A clone saved by `fit --save`, as a policy (the activation, layers and features
    it was fitted with: the pickle holds the weights only)."""
    cfg, venv, model = _model("linear", arch, activation, features)
    _load(path, venv, model)
    return _policy(cfg, venv, model, name)


def export(cfg, venv, model, out) -> None:
    """The clone as a run directory `load_policy` reads (best_model.zip, its metadata
    and VecNormalize statistics), written as train.py writes its models."""
    from pathlib import Path

    from hoprover_env.training.sb3_agents import env_kwargs
    from hoprover_env.training.train import save_model

    save_model(
        model,
        venv,
        Path(out) / "best_model",
        {
            "algo": cfg["algo"],
            "env_id": cfg["env_id"],
            "env_kwargs": env_kwargs(cfg),
            "config": cfg,
        },
    )


def collect_cmd(args) -> None:
    from hoprover_env.training.sb3_agents import env_kwargs
    from hoprover_env.training.warm_start import collect
    from research.plan_clone.gated import load_any as load_policy  # a research .pt too

    cfg, venv, model = _model(args.action_map, args.arch, args.activation, args.features)
    kwargs = {**env_kwargs(cfg), "target_range": tuple(args.target_range)}
    learner = None
    if args.learner:
        _load(args.learner, venv, model)
        learner = _policy(cfg, venv, model, "learner")
    t0 = time.perf_counter()
    obs, act, ret = collect(
        load_policy(args.expert, control_dt=0.5),
        kwargs,
        args.episodes,
        args.seed,
        cfg["hyperparams"]["gamma"],
        batch=args.batch,
        noise=args.noise,
        executor=learner,
        log=lambda m: print(m, flush=True),
    )
    np.savez(args.out, obs=obs, act=act, ret=ret)
    print(f"{len(obs)} steps in {time.perf_counter() - t0:.0f} s -> {args.out}")


def judge(policy) -> dict:
    """Validation (train.py's targets) and the level-v1 suite, by target distance."""
    from hoprover_env.evaluation import suites
    from hoprover_env.evaluation.episodes import run_episodes, seeded_targets, summarize

    val = summarize(run_episodes(policy, seeded_targets(100, 7), {}))
    suite = suites.load("HopRover-v0")
    rows = suites.run(policy, suite)
    reg = np.array([r["regret"] for r in rows])
    dist = np.abs(suite.targets)
    out = {
        "validation_success": val["success_rate"],
        "validation_median": val["median_ttrtp"],
        "suite_success": float(np.isfinite(reg).mean()),
        "median_regret": float(np.median(reg)),
        "worst_regret": float(reg.max()),
        "by_distance": [],
    }
    for lo, hi in BINS:
        r = reg[(dist >= lo) & (dist < hi)]
        out["by_distance"].append(
            {
                "range": (lo, hi),
                "episodes": len(r),
                "success": float(np.isfinite(r).mean()),
                "median_regret": float(np.median(r)),
                "worst_regret": float(r.max()),
            }
        )
    return out


def fit(
    data,
    *,
    epochs=100,
    batch_size=2048,
    lr=1e-3,
    lr_end=1e-5,
    ground_weight=10.0,
    launch_weight=None,
    start_weight=None,
    action_map="linear",
    arch=None,
    activation=None,
    features=None,
    init=None,
    save=None,
    export_dir=None,
    log=print,
) -> dict:
    """Fit a clone to the collections `data` (paths), save it (`save`: weights and
    statistics; `export_dir`: a run directory), and return `judge`'s results."""
    import torch

    from hoprover_env.training.warm_start import clone

    torch.set_num_threads(1)
    cfg, venv, model = _model(action_map, arch, activation, features)
    loaded = [np.load(p) for p in data]
    obs, act, ret = (np.concatenate([d[k] for d in loaded]) for k in ("obs", "act", "ret"))
    log(f"{len(obs)} samples from {len(data)} collections")
    if init:
        _load(init, venv, model, log)
    # a warm start keeps normalising with the statistics its weights were fitted to
    clone(
        model,
        venv,
        obs,
        act,
        ret,
        epochs=epochs,
        batch_size=batch_size,
        learning_rate=lr,
        learning_rate_end=lr_end,
        value_epochs=0,
        ground_weight=ground_weight,
        launch_weight=launch_weight,
        start_weight=start_weight,
        seed=0,
        log=log,
        fit_statistics=not init,
    )
    if save:
        save_clone(save, model, venv)
    if export_dir:
        export(cfg, venv, model, export_dir)
    return judge(_policy(cfg, venv, model))


def report(res: dict, log=print) -> None:
    """`judge`'s results as text; also those read back from its JSON, where a NaN or an
    infinity was written as null."""

    def numbers(d: dict) -> dict:
        return {k: float("nan") if v is None else v for k, v in d.items()}

    res = numbers(res)
    log(
        f"validation: success {res['validation_success']:.1%}, median TTRTP "
        f"{res['validation_median']:.1f} s"
    )
    log(
        f"level-v1: success {res['suite_success']:.1%}, median regret "
        f"{res['median_regret']:.3f}, worst {res['worst_regret']:.3f}"
    )
    for b in map(numbers, res["by_distance"]):
        log(
            f"  |d| in [{b['range'][0]}, {b['range'][1]}) m: {b['episodes']} episodes, "
            f"success {b['success']:.1%}, median regret {b['median_regret']:.3f}, worst "
            f"{b['worst_regret']:.3f}"
        )


def fit_cmd(args) -> None:
    log = lambda m: print(m, flush=True)  # noqa: E731
    report(
        fit(
            args.data,
            epochs=args.epochs,
            batch_size=args.batch_size,
            lr=args.lr,
            lr_end=args.lr_end,
            ground_weight=args.ground_weight,
            launch_weight=args.launch_weight,
            start_weight=args.start_weight,
            action_map=args.action_map,
            arch=args.arch,
            activation=args.activation,
            features=args.features,
            init=args.init,
            save=args.save,
            export_dir=args.export,
            log=log,
        ),
        log,
    )


def main(argv=None) -> int:
    from research.plan_clone.features import FEATURE_EXTRACTORS

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("collect", help="expert demonstrations or DAgger labels")
    c.add_argument("--out", required=True)
    c.add_argument("--seed", type=int, required=True)
    c.add_argument("--episodes", type=int, default=200)
    c.add_argument("--noise", type=float, default=0.01, help="DART noise on executed actions")
    c.add_argument("--target-range", type=float, nargs=2, default=(-1.0, 1.0))
    c.add_argument("--expert", default="mpc")
    c.add_argument("--learner", default=None, help="a clone saved by fit --save (DAgger)")
    c.add_argument("--batch", type=int, default=200, help="episodes side by side")
    c.add_argument("--action-map", default="linear", choices=("linear", "cubic"))
    f = sub.add_parser("fit", help="fit a clone to collections and judge it")
    f.add_argument("--data", nargs="+", required=True)
    f.add_argument("--epochs", type=int, default=100)
    f.add_argument("--batch-size", type=int, default=2048)
    f.add_argument("--lr", type=float, default=1e-3)
    f.add_argument("--lr-end", type=float, default=1e-5)
    f.add_argument("--ground-weight", type=float, default=10.0)
    f.add_argument(
        "--launch-weight",
        type=float,
        default=None,
        help="weight of the ground samples of the first 20 s (default: ground's)",
    )
    f.add_argument(
        "--start-weight",
        type=float,
        default=None,
        help="weight of the first decision at t = 0 (default: the launch's)",
    )
    f.add_argument("--init", default=None, help="start from a saved clone")
    f.add_argument("--export", default=None, help="also save it as a run directory")
    f.add_argument("--save", default=None)
    f.add_argument("--action-map", default="linear", choices=("linear", "cubic"))
    for p in (c, f):
        p.add_argument(
            "--arch",
            type=int,
            nargs="+",
            default=None,
            help="hidden layer sizes (default: the config's 256 256)",
        )
        p.add_argument(
            "--activation", default=None, help="hidden activation (default: the config's tanh)"
        )
        p.add_argument(
            "--features",
            default=None,
            choices=sorted(FEATURE_EXTRACTORS),
            help="inputs at fine scales (research.plan_clone.features)",
        )
    args = ap.parse_args(argv)
    (collect_cmd if args.cmd == "collect" else fit_cmd)(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
