"""Behaviour cloning before RL (a config's `pretrain` section): `Pretraining`, the part
of train.py's `Trainer` that runs the expert, fits the agent to its actions
(training/warm_start.py `collect`, `clone`), runs the DAgger rounds, keeps the best
clone, and keeps each collection in OUT/pretrain so that a run killed during its
pretraining starts again from its last finished one (`collection_key`: what a
collection depends on)."""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np

from hoprover_env.agents.policies import SB3Policy
from hoprover_env.training.sb3_agents import env_kwargs, pretrain_settings
from hoprover_env.util.files import write_json, write_npz


def _score(res: dict) -> tuple:
    """Evaluations are ranked by success rate, then by median TTRTP."""
    med = res["median_ttrtp"]
    return (res["success_rate"], -(med if not math.isnan(med) else 1e9))


def collection_key(cfg: dict, name: str) -> dict:
    """What one pretraining collection depends on: the expert, its seed, the env and the
    discount (the stored returns are discounted with it); the demonstrations also on
    their episodes and noise; a DAgger round also on the learner,
    i.e. on everything that shaped it (the whole pretraining, the policy, the
    normalisation and the seed)."""
    pt = pretrain_settings(cfg)
    key = {
        "env_id": cfg["env_id"],
        "env": cfg.get("env"),
        "expert": pt["expert"],
        "seed": pt["seed"],
        "gamma": cfg["hyperparams"].get("gamma", 0.99),
    }
    if name == "demonstrations":
        key.update(episodes=pt["episodes"], noise=pt["noise"])
    else:
        key.update(
            pretrain=cfg["pretrain"],
            policy=cfg.get("policy"),
            normalize=cfg.get("normalize"),
            run_seed=cfg["seed"],
        )
    return json.loads(json.dumps(key))


class Pretraining:
    """Behaviour cloning of the expert before RL, mixed into train.py's `Trainer`, whose
    cfg, out, model, venv, pretrain and `_judge` it uses."""

    def _pretrain(self):
        """Behaviour cloning of the expert: noisy demonstrations, then DAgger rounds."""
        import copy

        from hoprover_env.agents.policies import load_policy
        from hoprover_env.training.warm_start import clone, collect

        pt = pretrain_settings(self.cfg)
        ekw = env_kwargs(self.cfg)
        expert = load_policy(pt["expert"], control_dt=ekw.get("control_dt", 0.5))
        gamma = self.cfg["hyperparams"].get("gamma", 0.99)
        seed = pt["seed"]
        log = lambda m: print(m, file=sys.stderr)  # noqa: E731
        fit = {
            k: pt[k]
            for k in (
                "epochs",
                "batch_size",
                "learning_rate",
                "value_epochs",
                "log_std",
                "ground_weight",
                "learning_rate_end",
            )
        }
        fit.update(seed=self.cfg["seed"], log=log)
        t_start = time.perf_counter()
        timer = {"collect": 0.0, "fit": 0.0}

        def timed(key, fn, *args, **kwargs):
            t0 = time.perf_counter()
            out = fn(*args, **kwargs)
            timer[key] += time.perf_counter() - t0
            return out

        log(
            f"behaviour cloning: running the expert ({pt['episodes']} episodes, "
            f"then {pt['dagger_rounds']} DAgger rounds)"
        )
        data = self._collected(
            "demonstrations",
            lambda: timed(
                "collect",
                collect,
                expert,
                ekw,
                pt["episodes"],
                seed,
                gamma,
                noise=pt["noise"],
                log=log,
            ),
        )
        log(f"behaviour cloning: {len(data[0])} expert steps in {timer['collect']:.1f} s")
        timed("fit", clone, self.model, self.venv, *data, **fit)
        best = self._score_clone("cloned", None)
        for k in range(pt["dagger_rounds"]):
            norm = self.venv
            learner = SB3Policy(
                self.model,
                copy.deepcopy(norm.obs_rms),
                norm.clip_obs,
                epsilon=norm.epsilon,
                name="learner",
                env_kwargs=ekw,
            )
            new = self._collected(
                f"dagger_{k + 1}",
                lambda k=k, learner=learner: timed(
                    "collect",
                    collect,
                    expert,
                    ekw,
                    pt["dagger_episodes"],
                    seed + 1 + k,
                    gamma,
                    executor=learner,
                    log=log,
                ),
            )
            data = tuple(np.concatenate([a, b]) for a, b in zip(data, new))
            log(
                f"DAgger round {k + 1}/{pt['dagger_rounds']}: +{len(new[0])} learner steps "
                "labelled by the expert"
            )
            timed("fit", clone, self.model, self.venv, *data, **fit)
            best = self._score_clone(f"after DAgger round {k + 1}", best)
        # the rounds' scores scatter: keep the best clone (weights and the statistics its
        # observations were normalised with)
        score, state, rms, label = best
        self.model.policy.load_state_dict(state)
        self.venv.obs_rms, self.venv.ret_rms = rms
        print(f"  keeping the clone {label}", file=sys.stderr)
        if not self.cfg["normalize"].get("update", True):
            self.venv.training = False  # keep the statistics the clone was fitted to
        self.pretrain = {
            "pretrain_s": time.perf_counter() - t_start,
            "pretrain_collect_s": timer["collect"],
            "pretrain_fit_s": timer["fit"],
        }
        log(
            f"behaviour cloning took {self.pretrain['pretrain_s']:.0f} s: "
            f"{timer['collect']:.0f} s running the expert and the learner in the env, "
            f"{timer['fit']:.0f} s fitting, the rest judging the rounds"
        )

    def _collected(self, name: str, run) -> tuple:
        """The (obs, actions, returns) of one collection, kept in OUT/pretrain/NAME.npz:
        collecting from the expert is the slow part of cloning (minutes per round with
        mpc), so a run killed during its pretraining starts again from its last finished
        collection (the fits in between are repeated; they are seeded)."""
        path = self.out / "pretrain" / f"{name}.npz"
        key = path.with_suffix(".json")
        made_with = collection_key(self.cfg, name)
        if path.exists() and (not key.exists() or json.loads(key.read_text()) != made_with):
            print(f"  {path} was collected with other settings: collecting again", file=sys.stderr)
            path.unlink()
        if path.exists():
            with np.load(path) as f:
                print(f"  {name}: reusing {path}", file=sys.stderr)
                return f["obs"], f["act"], f["ret"]
        obs, act, ret = run()
        write_npz(path, obs=obs, act=act, ret=ret)
        write_json(key, made_with)
        return obs, act, ret

    def _score_clone(self, label: str, best):
        """Judge the current clone; return the better of it and `best` as
        (score, policy weights, (obs_rms, ret_rms), label)."""
        import copy

        norm = self.venv
        res = self._judge(label)
        print(
            f"  {label}: success {res['success_rate']:.1%}, median TTRTP "
            f"{res['median_ttrtp']:.1f} s, broken {res['broken']}",
            file=sys.stderr,
        )
        score = _score(res)
        if best is None or score > best[0]:
            best = (
                score,
                copy.deepcopy(self.model.policy.state_dict()),
                (copy.deepcopy(norm.obs_rms), copy.deepcopy(norm.ret_rms)),
                label,
            )
        return best
