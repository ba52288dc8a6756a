"""Frozen test suites: the versioned test episodes of every task, each with a replayable
best-known reference.

    from hoprover_env.evaluation import suites
    suite = suites.load("HopRover-v0")            # the newest version
    ep = suite[0]
    ep.target_x, ep.slope, ep.roughness, ep.terrain_seed, ep.control_dt
    ep.reference_ttrtp, ep.reference_schedule     # the best-known plan, as torques
    ep.replay().ttrtp == ep.reference_ttrtp       # bit for bit

=====================  ===============================================================
suite                  episodes
=====================  ===============================================================
``level``              200 targets from U(-1, 1) m on level, smooth ground
                       (HopRover-v0; HopRoverHop-v0 shares them: the physics is the
                       same, only the action differs)
``terrain``            200 (target, slope, terrain seed) triples: targets from U(-1, 1)
                       m, slopes from U(-0.2, 0.2) rad, roughness 0.05 rad
                       (HopRoverTerrain-v0)
``contest``            the contest's target, 0.5 m (HopRoverContest-v0)
=====================  ===============================================================

The episodes are drawn from seeds of their own (`SUITE_SEEDS`), which no training run
or validation uses: train.py validates on the env's own draws from seed 7 (the suites'
tests check that no suite target coincides with those) and `evaluate.py` without
``--suite`` on seed 2015.

A reference is the fastest plan a clairvoyant search found for that episode (on rough
ground it knew the episode's bumps), together with the plans of every bundled agent,
stored as the torque it commands in each control interval of `control_dt` (0.5 s); zero
torque after the schedule's end. It is *best-known*, not optimal.
`simulate(ep.reference_schedule, t_end=600, control_dt=ep.control_dt,
target_x=ep.target_x, params=RoverParams(slope=ep.slope, roughness=ep.roughness),
seed=ep.terrain_seed)` reproduces `ep.reference_ttrtp` bit for bit (`ep.replay()`).
`python -m research.yardstick.references` regenerates them (docs/studies/references.md gives
its budget).

What a suite file holds (an .npz, `save` and `load`): per episode the columns of
`FIELDS` (target, slope, roughness, terrain seed, control period, reference TTRTP) and the
reference schedule; the sources of the references; and, from format 2 on, the episodes'
*start conditions*: for each registered id whose env draws more than those columns fix
(HopRoverMission-v0 on the terrain suite: its unknown ground, restitution_x,
restitution_y, mu_static and mu_dynamic, its sensor seed `sensor_seed` and its actuator
draw `actuator_draw`), the values of those draws, as reset options (an array
``start/<id>/<option>`` each, listed in the meta's ``start``). So an env given
`Episode.reset_options(env_id)` starts exactly that episode, whatever it is seeded with.
The terrain suite's were taken once from the per-env numpy draws the suite was scored
with when frozen (episode e seeded e), so scores made since stay valid. An id the file
holds no conditions for draws what the columns leave open from the episode's seed
(episode e seeded e, tasks/draws.py).

A suite run fixes the episode's rover and ground: env_kwargs whose `randomize` differs
from the id's own (which would redraw them) are refused with a ValueError (`run`); the
other env arguments apply (a mission's `noise_scale` scales its frozen actuator draw).

Each suite file carries its version, a SHA-256 checksum of its episodes and references
(`Suite.checksum`, the one scores cite) and one of its start conditions
(``start_sha256``), both checked on load: a file that was changed by hand fails to load.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import numpy as np

from hoprover_env.core.params import RoverParams
from hoprover_env.envs.registry import ENVS, default_config

DATA_DIR = Path(__file__).resolve().parent / "suite_data"
EPISODE_TIME = 600.0
CONTROL_DT = 0.5
NO_TERRAIN_SEED = -1


def suite_of(env_id: str) -> str:
    """The name of the suite a registered id is scored on (its Registration's `suite`),
    read from the registry when called, so that a task registered later counts.
    ValueError for an unknown id or one registered without a suite."""
    if env_id not in ENVS:
        raise ValueError(f"unknown hoprover env id {env_id!r}; valid: {sorted(ENVS)}")
    name = ENVS[env_id].suite
    if name is None:
        raise ValueError(
            f"{env_id!r} is scored on no test suite: its Registration names "
            f"none (suite=None); registered ids with one: "
            f"{sorted(suite_ids())}"
        )
    return name


def suite_ids(name: str | None = None) -> list[str]:
    """The registered ids scored on the suite `name` (None: on any suite), in
    registration order, read from the registry when called."""
    return [
        env_id
        for env_id, spec in ENVS.items()
        if spec.suite is not None and (name is None or spec.suite == name)
    ]


def task_of(name: str) -> str:
    """The id whose env runs the suite `name`: the first registered id scored on it
    whose action is a torque held over a control period (not a hop). ValueError if no
    such id is registered."""
    for env_id in suite_ids(name):
        if not ENVS[env_id].hops:
            return env_id
    raise ValueError(f"no registered torque-level id is scored on the suite {name!r}")


# the seed each suite's episodes are drawn from (never used for training or validation)
SUITE_SEEDS = {"level": 1_000_001, "terrain": 1_000_002}
SIZES = {"level": 200, "terrain": 200}
CONTEST_TARGET = 0.5
FIELDS = ("target_x", "slope", "roughness", "terrain_seed", "control_dt", "reference_ttrtp")
FORMAT = 2  # suite files with start conditions (format 1: none)
START = "start"  # the prefix of a start condition's array: start/<id>/<option>


@dataclasses.dataclass(frozen=True)
class Episode:
    """One test episode and its best-known reference (see the module docstring)."""

    index: int
    target_x: float
    slope: float
    roughness: float
    terrain_seed: int  # -1 on smooth ground
    control_dt: float
    reference_ttrtp: float
    reference_schedule: np.ndarray
    reference_source: str  # which search or agent found the reference
    # the frozen start conditions, per registered id: {env_id: {reset option: value}}
    start: dict = dataclasses.field(default_factory=dict)

    @property
    def params(self) -> RoverParams:
        """The rover on this episode's ground (contest values otherwise)."""
        return RoverParams(slope=self.slope, roughness=self.roughness)

    @property
    def seed(self) -> int | None:
        """The terrain seed to pass to `simulate` (None on smooth ground)."""
        return None if self.terrain_seed == NO_TERRAIN_SEED else int(self.terrain_seed)

    def reset_options(self, env_id: str | None = None) -> dict:
        """The env reset options that start this episode: its target and ground, and
        with `env_id` that id's frozen start conditions (none for an id the suite holds
        none for)."""
        opts = {"target_x": self.target_x, "slope": self.slope, "roughness": self.roughness}
        if self.seed is not None:
            opts["terrain_seed"] = self.seed
        if env_id is not None:
            opts.update(self.start.get(env_id, {}))
        return opts

    def replay(self):
        """The reference plan through `simulate` (a Rollout whose ttrtp is the
        reference's)."""
        from hoprover_env.sim.simulate import simulate

        return simulate(
            self.reference_schedule,
            t_end=EPISODE_TIME,
            control_dt=self.control_dt,
            target_x=self.target_x,
            params=self.params,
            seed=self.seed,
        )


@dataclasses.dataclass(frozen=True)
class Suite:
    """The episodes of one suite version: index them, iterate them, or take columns
    (`targets`, `slopes`, `roughness`, `terrain_seeds`, `reference_ttrtp`)."""

    name: str
    version: int
    checksum: str
    episodes: tuple
    meta: dict

    def __len__(self) -> int:
        return len(self.episodes)

    def __getitem__(self, i) -> Episode:
        return self.episodes[i]

    def __iter__(self):
        return iter(self.episodes)

    def column(self, field: str) -> np.ndarray:
        return np.array([getattr(e, field) for e in self.episodes])

    @property
    def targets(self) -> np.ndarray:
        return self.column("target_x")

    @property
    def reference_ttrtp(self) -> np.ndarray:
        return self.column("reference_ttrtp")

    def terrain(self) -> dict:
        """Per-episode reset options beyond the target ({"slope", "roughness",
        "terrain_seed"}), as arrays for a vector env."""
        out = {"slope": self.column("slope"), "roughness": self.column("roughness")}
        seeds = self.column("terrain_seed")
        if (seeds != NO_TERRAIN_SEED).any():
            out["terrain_seed"] = seeds
        return out

    def conditions(self, env_id: str) -> dict:
        """Per-episode reset options beyond the target for an env of `env_id`, as arrays
        for a vector env: `terrain` and the id's frozen start conditions."""
        out = self.terrain()
        names = sorted({k for e in self.episodes for k in e.start.get(env_id, {})})
        for k in names:
            if not all(k in e.start.get(env_id, {}) for e in self.episodes):
                raise ValueError(
                    f"{self.name}-v{self.version}: the start condition {k!r} "
                    f"of {env_id} is missing for some episodes"
                )
            out[k] = np.array([e.start[env_id][k] for e in self.episodes])
        return out

    def start_ids(self) -> list[str]:
        """The ids this suite holds frozen start conditions for."""
        return sorted({i for e in self.episodes for i in e.start})

    def start_conditions(self) -> dict:
        """The frozen start conditions as `save` takes them: {env_id: {reset option: one
        value per episode}} (what a new version of the same episodes carries over)."""
        terrain = set(self.terrain())
        return {
            env_id: {k: v for k, v in self.conditions(env_id).items() if k not in terrain}
            for env_id in self.start_ids()
        }


def draw_episodes(name: str, seed: int | None = None, n: int | None = None) -> dict:
    """The episodes of a suite, drawn from its seed (no references): columns of
    FIELDS[:5]. `seed` and `n` draw `n` other episodes the same way (fresh ones, for a
    check on episodes nothing was chosen on: research/yardstick/fresh_targets.py)."""
    if name == "contest":
        return {
            "target_x": np.array([CONTEST_TARGET]),
            "slope": np.zeros(1),
            "roughness": np.zeros(1),
            "terrain_seed": np.full(1, NO_TERRAIN_SEED),
            "control_dt": np.full(1, CONTROL_DT),
        }
    rng = np.random.default_rng(SUITE_SEEDS[name] if seed is None else seed)
    n = SIZES[name] if n is None else n
    targets = rng.uniform(-1.0, 1.0, n)
    # the ground the suite's task draws, by its config (the terrain task's: a slope
    # range and a roughness)
    ground = default_config(task_of(name)).ground()
    if "slope" in ground:
        low, high = ground["slope"]
        slopes = rng.uniform(low, high, n)
        seeds = rng.integers(0, 2**63, n, dtype=np.int64)
        rough = np.full(n, ground["roughness"])
    else:
        slopes, rough = np.zeros(n), np.zeros(n)
        seeds = np.full(n, NO_TERRAIN_SEED, dtype=np.int64)
    return {
        "target_x": targets,
        "slope": slopes,
        "roughness": rough,
        "terrain_seed": seeds,
        "control_dt": np.full(n, CONTROL_DT),
    }


def checksum(columns: dict, schedules: list) -> str:
    """SHA-256 over the episodes' fields and reference schedules (their exact bytes)."""
    h = hashlib.sha256()
    for f in FIELDS:
        a = np.ascontiguousarray(columns[f])
        h.update(f.encode())
        h.update(a.dtype.str.encode())
        h.update(a.tobytes())
    for s in schedules:
        h.update(np.ascontiguousarray(s, dtype=np.float64).tobytes())
        h.update(b"|")
    return h.hexdigest()


def start_checksum(start: dict) -> str:
    """SHA-256 over the start conditions {env_id: {option: column}} (names, dtypes,
    exact bytes, in sorted order)."""
    h = hashlib.sha256()
    for env_id in sorted(start):
        for key in sorted(start[env_id]):
            a = np.ascontiguousarray(start[env_id][key])
            h.update(f"{START}/{env_id}/{key}".encode())
            h.update(a.dtype.str.encode())
            h.update(a.tobytes())
    return h.hexdigest()


def path_of(name: str, version: int) -> Path:
    return DATA_DIR / f"{name}-v{version}.npz"


def versions(name: str) -> list[int]:
    """The versions of a suite on disk, oldest first."""
    found = []
    for p in DATA_DIR.glob(f"{name}-v*.npz"):
        tail = p.stem.rsplit("-v", 1)[1]
        if tail.isdigit():
            found.append(int(tail))
    return sorted(found)


def save(
    name: str,
    version: int,
    columns: dict,
    schedules: list,
    sources: list,
    meta: dict,
    directory: Path | None = None,
    start: dict | None = None,
) -> Path:
    """Write a suite version (atomically: a temporary file, then a rename). `start`: the
    episodes' start conditions, {env_id: {reset option: one value per episode}}."""
    directory = Path(directory or DATA_DIR)
    directory.mkdir(parents=True, exist_ok=True)
    lengths = np.array([len(s) for s in schedules], dtype=np.int64)
    flat = (
        np.concatenate([np.asarray(s, dtype=np.float64) for s in schedules])
        if schedules
        else np.zeros(0)
    )
    digest = checksum(columns, schedules)
    start = {
        env_id: {k: np.asarray(v) for k, v in opts.items()}
        for env_id, opts in (start or {}).items()
    }
    meta = {
        **meta,
        "name": name,
        "version": version,
        "sha256": digest,
        "format": FORMAT,
        START: {env_id: sorted(opts) for env_id, opts in start.items()},
        "start_sha256": start_checksum(start),
    }
    arrays = {f"{START}/{env_id}/{k}": v for env_id, opts in start.items() for k, v in opts.items()}
    path = directory / f"{name}-v{version}.npz"
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(
        tmp,
        **{f: columns[f] for f in FIELDS},
        schedule_flat=flat,
        schedule_len=lengths,
        source=np.array(sources),
        meta=np.array(json.dumps(meta, sort_keys=True)),
        **arrays,
    )
    tmp.replace(path)
    return path


def load(env_id: str, version: int | None = None) -> Suite:
    """The test suite of a registered task (`suite_of`), at `version` (default: the
    newest). Raises ValueError naming an unknown id or version, an id registered without
    a suite, or a file whose checksum does not match its episodes."""
    name = suite_of(env_id)
    have = versions(name)
    if not have:
        raise ValueError(f"the {name!r} suite of {env_id!r} has no data file in {DATA_DIR}")
    if version is None:
        version = have[-1]
    if version not in have:
        raise ValueError(
            f"unknown version {version!r} of the {name!r} suite of {env_id!r}; versions: {have}"
        )
    return _read(path_of(name, version), name, version)


def _read(path: Path, name: str, version: int) -> Suite:
    with np.load(path, allow_pickle=False) as z:
        columns = {f: z[f] for f in FIELDS}
        cut = np.cumsum(z["schedule_len"])[:-1]
        schedules = np.split(z["schedule_flat"], cut)
        sources = [str(s) for s in z["source"]]
        meta = json.loads(str(z["meta"]))
        start = {
            env_id: {k: z[f"{START}/{env_id}/{k}"] for k in keys}
            for env_id, keys in meta.get(START, {}).items()
        }
        stray = [
            f
            for f in z.files
            if f.startswith(START + "/")
            and f.split("/", 2)[2] not in meta.get(START, {}).get(f.split("/")[1], ())
        ]
    digest = checksum(columns, schedules)
    if digest != meta.get("sha256"):
        raise ValueError(
            f"{path}: checksum mismatch (the file says {meta.get('sha256')}, "
            f"its episodes hash to {digest}); the suite was modified"
        )
    if meta.get("format", 1) >= 2 and (stray or start_checksum(start) != meta.get("start_sha256")):
        raise ValueError(
            f"{path}: checksum mismatch of the start conditions (the file "
            f"says {meta.get('start_sha256')}, they hash to "
            f"{start_checksum(start)}); the suite was modified"
        )
    n = len(columns["target_x"])
    for env_id, opts in start.items():
        for k, v in opts.items():
            if len(v) != n:
                raise ValueError(
                    f"{path}: the start condition {env_id}/{k} has {len(v)} values for {n} episodes"
                )
    episodes = tuple(
        Episode(
            index=i,
            target_x=float(columns["target_x"][i]),
            slope=float(columns["slope"][i]),
            roughness=float(columns["roughness"][i]),
            terrain_seed=int(columns["terrain_seed"][i]),
            control_dt=float(columns["control_dt"][i]),
            reference_ttrtp=float(columns["reference_ttrtp"][i]),
            reference_schedule=schedules[i],
            reference_source=sources[i],
            start={
                env_id: {k: v[i].item() for k, v in opts.items()} for env_id, opts in start.items()
            },
        )
        for i in range(n)
    )
    return Suite(name=name, version=version, checksum=digest, episodes=episodes, meta=meta)


def run(
    policy,
    suite: Suite,
    batch: int = 256,
    progress=None,
    env_kwargs: dict | None = None,
    workers: int | None = None,
) -> list[dict]:
    """Episodes of `suite` with `policy` (an ``act(obs, venv)`` policy), judged by the
    contest judge: `judged` rows (one dict per episode). `env_kwargs` are further env
    arguments (say a mission task's noise_scale); the suite's episode time stays, and so
    does every episode's start (its target, ground and the frozen start conditions of
    the policy's env id). `workers`: processes for a policy that may be spread over them
    (`run_episodes`; None: the policy's own, mpc's one per core; 1: this process only).
    Raises ValueError for env arguments that would redraw the frozen rover or ground
    (`randomize`, see the module docstring)."""
    return judged(run_results(policy, suite, batch, progress, env_kwargs, workers), suite)


def run_results(
    policy,
    suite: Suite,
    batch: int = 256,
    progress=None,
    env_kwargs: dict | None = None,
    workers: int | None = None,
) -> list:
    """`run`'s episodes, unjudged: run_episodes' EpisodeResults, in order."""
    from hoprover_env.evaluation.episodes import policy_env_id, run_episodes

    env_id = policy_env_id(policy)
    check_frozen(env_id, {**(env_kwargs or {}), **getattr(policy, "env_kwargs", {})})
    return run_episodes(
        policy,
        suite.targets,
        env_kwargs={**(env_kwargs or {}), "episode_time": EPISODE_TIME},
        batch=batch,
        progress=progress,
        terrain=suite.conditions(env_id),
        workers=workers,
    )


def check_frozen(env_id: str, env_kwargs: dict) -> None:
    """Refuse env arguments that would redraw what a suite's episodes fix: a `randomize`
    other than the id's own (its episodes' rover and ground are the suite's)."""
    if "randomize" not in env_kwargs:
        return
    from hoprover_env.sim.randomize import check_randomize

    own = default_config(env_id).randomize
    try:
        given = check_randomize(env_kwargs["randomize"])
    except ValueError:
        given = env_kwargs["randomize"]
    if given != own:
        raise ValueError(
            f"a test suite fixes each episode's rover and ground: "
            f"randomize={env_kwargs['randomize']!r} would redraw them; "
            f"leave randomize at {env_id}'s own ({own or None!r})"
        )


def judged(results, suite: Suite) -> list[dict]:
    """Judged episodes (objects with `as_dict()`, `success` and `ttrtp`, one per episode
    of `suite`, in order) as dicts with the episode's ground, `reference_ttrtp`,
    `regret` (ttrtp / reference, inf on failure) and `score` (reference / ttrtp, 0 on
    failure) added."""
    from hoprover_env.evaluation.scores import episode_regrets, episode_scores

    if len(results) != len(suite):
        raise ValueError(
            f"{len(results)} results for the {len(suite)} episodes of {suite.name}-v{suite.version}"
        )
    ttrtp = [r.ttrtp if r.success else None for r in results]
    scores = episode_scores(ttrtp, suite.reference_ttrtp)
    regrets = episode_regrets(ttrtp, suite.reference_ttrtp)
    out = []
    for r, ep, sc, g in zip(results, suite.episodes, scores, regrets):
        row = r.as_dict()
        row.update(
            suite=f"{suite.name}-v{suite.version}",
            slope=ep.slope,
            roughness=ep.roughness,
            terrain_seed=ep.terrain_seed,
            reference_ttrtp=ep.reference_ttrtp,
            regret=float(g),
            score=float(sc),
        )
        out.append(row)
    return out
