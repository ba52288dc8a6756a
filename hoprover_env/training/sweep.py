"""Hyperparameter and seed sweeps of train.py's trainer on Ray Tune.

    python sweep.py --config configs/ppo_scratch.yaml --seeds 0-7 \\
        --search "learning_rate=loguniform(1e-5,1e-3)" --samples 16 --name lr
    python sweep.py ... --address HEAD:6379 --out /shared/sweeps   # the same on a cluster

Each trial is train.py's Trainer (the same config, checks, evaluations and files) with
the sampled values applied. Optuna proposes the values (Tune's OptunaSearch); ASHA stops
trials whose judged success rate lags at an evaluation (each `evaluation.freq` steps is
one ASHA time unit; --grace counts those after training has started, as the evaluation
at step 0 tells the trials' seeds apart, not their settings). Trial k (Tune's k-th trial,
from 0) trains with seed SEEDS[k mod len(SEEDS)]: seeds are spread over the trials, never
searched over (picking a lucky seed is not tuning). One CPU per trial by default.

Search terms, repeatable: NAME=uniform(a,b) | loguniform(a,b) | randint(a,b) |
choice(a|b|...). NAME is a config key: a bare `learning_rate` is looked up in
`hyperparams`, then `env`, then `policy`; `env.time_cost` names the section.

--out is Tune's storage (a directory every node mounts at the same path, or a URI such
as s3://bucket/sweeps). OUT/NAME holds Tune's experiment state, each trial's folder
(its train.py run directory in run/, and Tune checkpoints checkpoint_*/run reported
with its evaluations) and, at the end, best_config.yaml, which `python train.py
--config OUT/NAME/best_config.yaml --out ...` accepts unchanged. A trial whose node dies
restarts from its last checkpoint on another node (--max-failures); its run's
evaluations.csv lists each evaluation once, but Tune's result.json may list twice the one
reported just before the loss, when Tune had not yet stored that report's checkpoint (it
restores the one before, and the trial reports that evaluation again). Ctrl-C stops the
sweep with exit code 130, writes no best config and prints the command that resumes
it: running the same command again keeps finished trials and continues unfinished ones
from their last checkpoint. Without --address (or RAY_ADDRESS) it starts a local Ray
on this machine's cores; through ray://HOST:10001 Tune's driver runs on the head node.
"""

from __future__ import annotations

import argparse
import copy
import hashlib
import json
import math
import re
import sys
from pathlib import Path

import yaml

from hoprover_env.training.sb3_agents import ConfigError, load_config

DISTRIBUTIONS = ("uniform", "loguniform", "randint", "choice")
METRIC = "score"  # success rate, ties broken by a faster median TTRTP


def parse_seeds(text: str) -> list[int]:
    """'0-7' or '0,3,5' or '4' -> a list of ints."""
    seeds: list[int] = []
    for part in text.split(","):
        m = re.fullmatch(r"\s*(-?\d+)\s*(?:-\s*(-?\d+)\s*)?", part)
        if not m:
            raise ValueError(f"--seeds wants e.g. 0-7 or 0,3,5; got {text!r}")
        lo = int(m.group(1))
        hi = int(m.group(2)) if m.group(2) is not None else lo
        if hi < lo:
            raise ValueError(f"--seeds range {part!r} is empty")
        seeds.extend(range(lo, hi + 1))
    return seeds


def parse_search(term: str, cfg: dict) -> tuple[tuple[str, str], str, list]:
    """'learning_rate=loguniform(1e-5,1e-3)' -> (('hyperparams', 'learning_rate'),
    'loguniform', [1e-5, 1e-3]), with the key resolved against the config."""
    m = re.fullmatch(r"\s*([\w.]+)\s*=\s*(\w+)\((.*)\)\s*", term)
    if not m:
        raise ValueError(
            f"--search wants NAME=DIST(ARGS), e.g. learning_rate=loguniform(1e-5,"
            f"1e-3); got {term!r}"
        )
    name, dist, args = m.groups()
    if dist not in DISTRIBUTIONS:
        raise ValueError(
            f"--search {name}: distribution must be one of {DISTRIBUTIONS}, got {dist!r}"
        )
    if dist == "choice":
        values = [yaml.safe_load(v) for v in args.split("|")]
    else:
        try:
            values = [float(v) for v in args.split(",")]
        except ValueError:
            raise ValueError(f"--search {name}: {dist} wants two numbers, got ({args})") from None
        if len(values) != 2 or not values[0] < values[1]:
            raise ValueError(
                f"--search {name}: {dist} wants (low, high) with low < high, got ({args})"
            )
        if dist == "loguniform" and values[0] <= 0:
            raise ValueError(f"--search {name}: loguniform needs low > 0, got {values[0]}")
        if dist == "randint":
            values = [int(v) for v in values]
    if "." in name:
        section, key = name.split(".", 1)
        if section not in SECTIONS or key not in section_keys(cfg, section):
            raise ValueError(f"--search {name}: not a key of {section!r}")
        return (section, key), dist, values
    for section in SECTIONS:
        if name in section_keys(cfg, section):
            return (section, name), dist, values
    raise ValueError(f"--search {name}: not a key of hyperparams, env or policy")


SECTIONS = ("hyperparams", "env", "policy")


def section_keys(cfg: dict, section: str) -> set:
    """The keys a config section accepts (those hoprover_env.training.sb3_agents.validate
    checks)."""
    from hoprover_env.training.sb3_agents import hyper_keys, policy_keys

    if section == "hyperparams":
        return hyper_keys(cfg["algo"])
    if section == "env":
        from hoprover_env.envs.registry import config_class

        return config_class(cfg["env_id"]).option_names()
    return policy_keys(cfg["algo"])


def _validate(cfg: dict) -> None:
    from hoprover_env.training.sb3_agents import validate

    validate(cfg)


def apply_params(cfg: dict, params: dict, paths: dict) -> dict:
    """The base config with sampled values put in place (then validated)."""
    out = copy.deepcopy(cfg)
    for name, value in params.items():
        section, key = paths[name]
        out[section] = {**out[section], key: value}
    _validate(out)
    return out


def score(row: dict) -> float:
    """Success rate, with a faster median TTRTP breaking ties (at most 0.006 of it)."""
    med = row["median_ttrtp"]
    return row["success_rate"] - 1e-5 * (600.0 if med is None or math.isnan(med) else med)


def parse_args(argv=None):
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=__doc__.split("\n", 2)[2],
    )
    ap.add_argument("--config", required=True, help="base YAML config (configs/*.yaml)")
    ap.add_argument("--search", action="append", default=[], help="NAME=DIST(ARGS), repeatable")
    ap.add_argument("--seeds", default="0", help="seeds spread over the trials: 0-7 or 0,3,5")
    ap.add_argument("--samples", type=int, default=8, help="number of trials")
    ap.add_argument("--name", default=None, help="sweep name (default: the config's stem)")
    ap.add_argument(
        "--out",
        default=str(Path("runs") / "sweeps"),
        help="Tune's storage: a directory every node mounts at the same path, "
        "or a URI (s3://...); default runs/sweeps (one machine)",
    )
    ap.add_argument("--timesteps", type=int, default=None, help="override the config's budget")
    ap.add_argument("--cpus-per-trial", type=float, default=1.0)
    ap.add_argument(
        "--grace",
        type=int,
        default=2,
        help="evaluations after training has started that every trial gets "
        "before ASHA may stop it (the one at step 0 does not count)",
    )
    ap.add_argument(
        "--address",
        default=None,
        help="Ray cluster address (HOST:6379 on a node, ray://HOST:10001 from "
        "outside); default RAY_ADDRESS or a local Ray",
    )
    from hoprover_env.training.ray_utils import SHIP_CODE_HELP

    ap.add_argument("--ship-code", action="store_true", help=SHIP_CODE_HELP)
    ap.add_argument(
        "--max-failures",
        type=int,
        default=3,
        help="restarts of a trial from its last checkpoint after its node or "
        "worker dies (default 3)",
    )
    ap.add_argument("--num-cpus", type=int, default=None, help="CPUs of a local Ray")
    args = ap.parse_args(argv)
    if args.samples < 1:
        ap.error(f"--samples must be at least 1, got {args.samples}")
    if args.grace < 1:
        ap.error(f"--grace must be at least 1, got {args.grace}")
    if not args.cpus_per_trial > 0:
        ap.error(f"--cpus-per-trial must be > 0, got {args.cpus_per_trial}")
    try:
        args.seeds = parse_seeds(args.seeds)
    except ValueError as exc:
        ap.error(str(exc))
    return args


def trial_index(dir_name: str, trial_id: str, first: int) -> int:
    """The trial's running number k (0, 1, ...): Tune's experiment tag follows the trial id
    in its directory name ('trainable_43dc18a6_4_learning_rate=...'), counted from 1 by a
    search algorithm and from 0 without one (`first`); a hash of the id if it is not there."""
    m = re.match(r"_(\d+)", dir_name.split(trial_id, 1)[1]) if trial_id in dir_name else None
    return int(m.group(1)) - first if m else int(hashlib.sha1(trial_id.encode()).hexdigest(), 16)


def asha_grace(grace: int, n_evals: int) -> int:
    """ASHA's grace period in reported evaluations: `grace` trained ones after the one at
    step 0. That one scores the untrained policy, which differs between trials by seed
    alone: a rung there stops trials for the seed they drew, not for their settings."""
    return min(grace + 1, n_evals)


REPORTED = "tune_reported.json"  # in a Tune checkpoint: the evaluations Tune has


def _snapshot(run: Path, reported: list[int]):
    """The trial's run directory, with the list of reported evaluations, as a Tune
    checkpoint (Tune copies it to the sweep's storage and deletes nothing of ours)."""
    import shutil
    import tempfile

    from ray import tune

    tmp = Path(tempfile.mkdtemp(prefix="hoprover-ckpt-"))
    shutil.copytree(run, tmp / "run", ignore=shutil.ignore_patterns(".tmp-*"))
    (tmp / REPORTED).write_text(json.dumps(reported))
    return tmp, tune.Checkpoint.from_directory(str(tmp))


def make_trainable(base: dict, paths: dict, seeds: list[int], first: int, expected: dict):
    def trainable(config: dict):
        import shutil

        import ray
        import torch
        from ray import tune

        from hoprover_env.util.buildinfo import require

        require(expected)
        from hoprover_env.training.train import Trainer

        torch.set_num_threads(1)
        ctx = tune.get_context()
        trial_id = ctx.get_trial_id()
        index = trial_index(Path(ctx.get_trial_dir()).name, trial_id, first)
        cfg = apply_params(base, config, paths)
        cfg["seed"] = seeds[index % len(seeds)]
        run = Path(ctx.get_trial_dir()) / "run"  # Tune's trial folder, in storage or staged
        shutil.rmtree(run, ignore_errors=True)
        restored = tune.get_checkpoint()
        reported: list[int] = []
        if restored is not None:  # this trial ran before, here or on another node
            with restored.as_directory() as d:
                shutil.copytree(Path(d) / "run", run)
                reported = json.loads((Path(d) / REPORTED).read_text())
        trainer = Trainer(cfg, run, restored is not None, "cpu", progress=False)
        if (run / "final_model.json").exists() and trainer.model.num_timesteps >= cfg["timesteps"]:
            return  # it had finished (the sweep stopped before Tune noted it)
        final: list[dict] = []
        resumed_at = int(trainer.model.num_timesteps)  # 0 unless restored

        def report(row, defer=True):
            if row["timesteps"] in reported:
                return  # Tune has it from before the restart: list it once
            if defer and row["timesteps"] >= cfg["timesteps"]:
                final.append(row)  # reported with the finished run below
                return
            reported.append(row["timesteps"])
            metrics = {
                **row,
                METRIC: score(row),
                "seed": cfg["seed"],
                "index": index,
                "trial_id": trial_id,
                "resumed_at": resumed_at,
                "node": ray.get_runtime_context().get_node_id(),
            }
            if not (run / "checkpoints" / "last.json").exists():
                tune.report(metrics)
                return
            tmp, checkpoint = _snapshot(run, reported)
            try:
                tune.report(metrics, checkpoint=checkpoint)
            finally:
                shutil.rmtree(tmp, ignore_errors=True)

        trainer.on_eval = report
        trainer.run()
        for row in final:  # the last evaluation, with the finished run's files
            report(row, defer=False)

    return trainable


def best_config_path(sweep_dir: str) -> str:
    return f"{sweep_dir.rstrip('/')}/best_config.yaml"


def storage_root(out: str) -> str:
    """--out as Tune's storage_path: a URI (s3://, gs://, ...) as given, a path made
    absolute (on a cluster it must be a mount every node shares, at the same path)."""
    return out if "://" in out else str(Path(out).resolve())


def write_text(path: str, text: str) -> None:
    """Write a file atomically, on a local path or at a URI (through pyarrow's
    filesystems, as Tune does)."""
    if "://" not in path:
        from hoprover_env.util.files import atomic_write

        atomic_write(path, text)
        return
    import pyarrow.fs

    fs, inner = pyarrow.fs.FileSystem.from_uri(path)
    with fs.open_output_stream(inner) as fh:
        fh.write(text.encode())


def unfinished(sweep_dir: str, samples: int) -> bool:
    """Whether Tune stopped before every trial ended (Ctrl-C). Tune saves the
    experiment's state as it stops, before it winds the trials down (which marks them
    all terminated in memory): fewer trials than asked for, or one not ended there,
    means an interrupted sweep."""
    from ray.tune import ExperimentAnalysis

    trials = ExperimentAnalysis(sweep_dir).trials
    return len(trials) < samples or any(t.status not in ("TERMINATED", "ERROR") for t in trials)


class _StopFlag:
    """Ctrl-C for Tune's driver on the head, set by a ray:// client (an actor)."""

    def __init__(self):
        self.set = False

    def stop(self):
        self.set = True

    def stopped(self) -> bool:
        return self.set


def _watch(flag, done) -> None:
    """In Tune's driver: turn the client's Ctrl-C into this process's (Tune then stops
    as it does on a node: saving its state)."""
    import _thread

    import ray

    while not done.wait(1.0):
        try:
            if ray.get(flag.stopped.remote(), timeout=30):
                _thread.interrupt_main()
                return
        except Exception:  # noqa: BLE001 - the client is gone: nothing to watch
            return


def run_sweep(args, base: dict, searched: list, expected: dict, flag=None) -> dict:
    """The Tune part of a sweep, run where Ray's driver is (in this process, or on the
    head node for a ray:// client, whose Ctrl-C arrives through `flag`). Returns the
    trial rows, whether Tune was interrupted, and the best config written (None if it
    was not)."""
    import threading

    done = threading.Event()
    if flag is not None:
        threading.Thread(target=_watch, args=(flag, done), daemon=True).start()
    try:
        return _run_sweep(args, base, searched, expected)
    finally:
        done.set()


def _run_sweep(args, base: dict, searched: list, expected: dict) -> dict:
    import ray
    from ray import tune
    from ray.tune import CheckpointConfig, FailureConfig, RunConfig
    from ray.tune.schedulers import ASHAScheduler
    from ray.tune.search.optuna import OptunaSearch

    from hoprover_env.training.ray_utils import check_storage

    name = args.name or Path(args.config).stem
    storage = storage_root(args.out)
    sweep_dir = f"{storage.rstrip('/')}/{name}"
    check_storage(ray, storage)
    space, paths = {}, {}
    for (section, key), dist, values in searched:
        paths[key] = (section, key)
        space[key] = {
            "uniform": lambda v: tune.uniform(*v),
            "loguniform": lambda v: tune.loguniform(*v),
            "randint": lambda v: tune.randint(v[0], v[1] + 1),
            "choice": lambda v: tune.choice(v),
        }[dist](values)
    n_evals = base["timesteps"] // base["evaluation"]["freq"] + 2
    trainable = tune.with_resources(
        make_trainable(base, paths, args.seeds, 1 if space else 0, expected),
        {"cpu": args.cpus_per_trial},
    )
    if tune.Tuner.can_restore(sweep_dir):
        print(f"resuming the sweep in {sweep_dir}", file=sys.stderr)
        tuner = tune.Tuner.restore(
            sweep_dir, trainable, resume_unfinished=True, resume_errored=True
        )
    else:
        tuner = tune.Tuner(
            trainable,
            param_space=space,
            tune_config=tune.TuneConfig(
                num_samples=args.samples,
                search_alg=OptunaSearch(metric=METRIC, mode="max", seed=args.seeds[0])
                if space
                else None,
                scheduler=ASHAScheduler(
                    metric=METRIC,
                    mode="max",
                    max_t=n_evals,
                    grace_period=asha_grace(args.grace, n_evals),
                ),
            ),
            run_config=RunConfig(
                name=name,
                storage_path=storage,
                verbose=0,
                failure_config=FailureConfig(max_failures=args.max_failures),
                checkpoint_config=CheckpointConfig(num_to_keep=2),
            ),
        )
    results = tuner.fit()
    rows = []
    for r in results:
        m = r.metrics or {}
        rows.append(
            {
                "trial": m.get("trial_id") or (Path(r.path).name if r.path else "?"),
                "seed": m.get("seed"),
                **{k: (r.config or {}).get(k) for k in space},
                "evals": m.get("training_iteration"),
                "timesteps": m.get("timesteps"),
                "success": m.get("success_rate"),
                "median_ttrtp": m.get("median_ttrtp"),
                METRIC: m.get(METRIC),
                "error": r.error is not None,
                "config": {k: (r.config or {}).get(k) for k in space},
            }
        )
    out = {
        "rows": rows,
        "keys": list(space),
        "interrupted": unfinished(sweep_dir, args.samples),
        "best": None,
        "sweep_dir": sweep_dir,
    }
    done = [row for row in rows if row[METRIC] is not None]
    if out["interrupted"] or not done:
        return out
    best = max(done, key=lambda row: row[METRIC])
    cfg = apply_params(base, best["config"], paths)
    cfg["seed"] = best["seed"]
    out["best"] = best_config_path(sweep_dir)
    write_text(
        out["best"],
        f"# best trial of sweep {name}: success {best['success']}, "
        f"median TTRTP {best['median_ttrtp']}\n" + yaml.safe_dump(cfg, sort_keys=False),
    )
    return out


def resume_command(argv: list[str] | None, address: str | None) -> str:
    """The command that resumes this sweep: the same one, with the address spelled out
    when it came from RAY_ADDRESS."""
    import shlex

    argv = list(sys.argv[1:] if argv is None else argv)
    if address and "--address" not in argv and not any(a.startswith("--address=") for a in argv):
        argv += ["--address", address]
    return shlex.join(["python", "sweep.py", *argv])


def main(argv=None) -> int:
    args = parse_args(argv)
    try:
        base = load_config(args.config, {"timesteps": args.timesteps})
        searched = [parse_search(t, base) for t in args.search]
    except (ConfigError, FileNotFoundError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    try:
        import optuna  # noqa: F401
        import ray  # noqa: F401
        from ray import tune  # noqa: F401
        from ray.tune.search.optuna import OptunaSearch  # noqa: F401
    except ImportError as exc:
        print(
            f"error: sweeps need Ray Tune and Optuna: pip install 'hoprover[ray]' ({exc})",
            file=sys.stderr,
        )
        return 2
    from hoprover_env.training.ray_utils import (
        ClusterCodeError,
        StorageError,
        cluster_address,
        head_node_strategy,
        init_ray,
        is_client,
    )
    from hoprover_env.util.buildinfo import build_info

    address = cluster_address(args.address)
    again = resume_command(argv, address)
    ref = None
    try:
        ray = init_ray(address, args.num_cpus, args.ship_code)
        expected = build_info()
        if is_client(address):
            # Tune's driver runs on the head, next to the storage it must read and write
            flag = ray.remote(num_cpus=0)(_StopFlag).remote()
            task = ray.remote(num_cpus=0, max_retries=0)(run_sweep).options(
                scheduling_strategy=head_node_strategy(ray)
            )
            ref = task.remote(args, base, searched, expected, flag)
            out = ray.get(ref)
        else:
            out = run_sweep(args, base, searched, expected)
    except (ClusterCodeError, StorageError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        out = None
        if ref is not None:
            # Ctrl-C reaches only this client: pass it to Tune's driver on the head, which
            # then stops as it does on a node (saving its state); collect its table
            try:
                ray.get(flag.stop.remote(), timeout=30)
                out = ray.get(ref, timeout=300)
            except (KeyboardInterrupt, Exception):  # noqa: BLE001 - a second Ctrl-C, ...
                out = None
        if out is None:
            print(
                f"\ninterrupted: the sweep is not finished and no best config was "
                f"written. Resume it with:\n  {again}",
                file=sys.stderr,
            )
            return 130
    print(format_trials(out["rows"], out["keys"]))
    if out["interrupted"]:
        print(
            f"\ninterrupted: partial results above; no best config was written. Resume "
            f"the sweep with:\n  {again}",
            file=sys.stderr,
        )
        return 130
    if out["best"] is None:
        print("error: no trial reported an evaluation", file=sys.stderr)
        return 1
    print(f"\nbest config: {out['best']}")
    return 0


def format_trials(rows: list[dict], keys: list[str]) -> str:
    def fmt(v):
        if v is None:
            return "-"
        if isinstance(v, float):
            return "-" if math.isnan(v) else f"{v:.4g}"
        return str(v)

    cols = ["trial", "seed", *keys, "evals", "timesteps", "success", "median_ttrtp", METRIC]
    table = [
        [fmt(row.get(c)) + ("  (error)" if c == METRIC and row["error"] else "") for c in cols]
        for row in rows
    ]
    widths = [max(len(c), *(len(r[i]) for r in table)) for i, c in enumerate(cols)]
    lines = [
        "  ".join(c.ljust(w) for c, w in zip(cols, widths)),
        "  ".join("-" * w for w in widths),
    ]
    lines += ["  ".join(v.ljust(w) for v, w in zip(r, widths)) for r in table]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
