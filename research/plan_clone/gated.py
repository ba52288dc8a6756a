"""A torque network of two branches, one for the nudge at the band's edge.

A clone of the plan-table teacher (research/plan_clone/plan_table.py) flies the long and short hops
within 1 % of the best-known plans, but one network fitted to everything at once does
not also fit the teacher's nudge law at the band's edge (research/plan_clone/nudge.py): its brakes
are a few thousand samples among millions, and a network fitted to those states alone
does fit them (docs/studies/plan-clone.md, section 3). So the network has two
branches and a fixed gate:

* the *main* branch (an MLP on the normalised observation) acts everywhere else; its
  actions below `deadzone` in size are zero (after a landing the teacher's label is
  zero torque, and the residual 0.01-0.02 of T_max a fit leaves there makes the rover
  rock and slide past the target);
* the *nudge* branch (an MLP on the normalised observation and `features.micro`
  inputs) acts where the rover is nearly still within `nudge_max` of the target
  (`near_edge`, the states the nudge law labels);
* with `flight`, the nudge branch also acts in slow flights within `nudge_max` (a
  nudge ends in a micro-flight of ~10 s in which the teacher coasts; the main branch's
  few thousandths of T_max there damp the rotation whose corner touch slides the rover
  into the band, and cost a second nudge: docs/studies/plan-clone.md, section 9);
* with `rest`, the gate measures the offset on the ground as the *rest offset*: where
  the c.m. would be if the rover were set down flat on the corner it stands on
  (`rest_offset`). A launch's pivot carries the c.m. toward the target while the corner
  stays put, so with the c.m.'s offset a plan launched from just beyond `nudge_max`
  was handed to the nudge branch half a second later: in a window of 0.07 mm beyond
  0.115 m every start took 41 s where a hop takes 30 (docs/studies/plan-clone.md,
  section 13);
* with `hold`, a rover at rest on a face (state F) with a corner in the band gets zero
  torque (`at_rest_in_band`): staying still then ends the episode in the least time
  there is. The teacher's label there is zero too, but the nudge law's push begins at
  the band's edge, a step that a fit smooths into a small push just inside it: without
  the hold every start within 0.36 mm of the edge was tipped out of the band (8-14 s
  where staying takes 5: docs/studies/plan-clone.md, section 10);
* with `symmetric`, each branch's output is the odd part of its fit under the mirror
  x -> -x (`tasks.observation.mirror`): (f(o) - f(mirror(o))) / 2, before the dead zone
  and the gate (both mirror-invariant). Level ground is mirror-symmetric, so the
  teacher is odd; an unsymmetrised fit is not, and its one-sided errors in
  micro-flights at the band's edge cost tens of times the plan's time
  (docs/studies/plan-clone.md, section 5).

Both branches are learned; the gate, the hold, the dead zone and the normalisations are
fixed parts of the network. `GatedNet.forward` maps raw observations (N, 19) to actions
(N, 1); `GatedPolicy` is the policy `load_policy` returns for a saved one (a .pt file:
the weights, with the branches' sizes in its metadata).
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import torch
from torch import nn

from hoprover_env.core.layout import MODE_A, MODE_F, MODE_LETTERS
from hoprover_env.core.params import RoverParams
from hoprover_env.tasks.observation import (
    OBS_DX,
    OBS_MODE,
    OBS_REF,
    OBS_SIN,
    OBS_VX,
    POS_SCALE,
    VEL_SCALE,
    mirror,
)

NUDGE_MAX = 0.115  # m: `near_edge`'s reach beyond the target
STILL_TILT, STILL_SPEED = 0.01, 1e-3  # rad, m/s: a nudge tilts and moves less
FLIGHT_TILT = 0.05  # rad: a nudge's micro-flight tilts up to ~0.02
# |OBS_REF| (the contact point's offset in band half-widths) below which `hold` holds:
# 5e-8 m inside the edge, so float32 round-off never holds a rover just outside the band
HOLD_REF = 1.0 - 1e-6
# HopRover-v0's rover and band (the only task a gated network acts in): `rest_offset`
# reads them on every forward pass, so they are taken once here
_LEVEL = RoverParams()
HALF_WIDTH, BAND_HALF_WIDTH = _LEVEL.half_width, _LEVEL.band_half_width


def observed_mode(obs):
    """The contact state (0..6 = A..G) of raw observations (numpy or torch): the index
    of their one-hot slots."""
    lib = torch if isinstance(obs, torch.Tensor) else np
    return lib.argmax(obs[:, OBS_MODE : OBS_MODE + len(MODE_LETTERS)], 1)


def rest_offset(obs):
    """c.m. minus target [m] of a rover set down flat on the corner it stands on, for raw
    observations (numpy or torch) of HopRover-v0's rover on the ground: OBS_REF is that
    corner (the one nearer the target at rest on a face), and the c.m. rests half a
    width beyond it on the c.m.'s side. At rest on a face it is the c.m.'s offset;
    pivoting on a corner it does not move with the tilt, only with the corner's slip."""
    lib = torch if isinstance(obs, torch.Tensor) else np
    corner = obs[:, OBS_REF] * BAND_HALF_WIDTH
    return corner + HALF_WIDTH * lib.sign(obs[:, OBS_DX] * POS_SCALE - corner)


def near_edge(obs, nudge_max: float = NUDGE_MAX, flight: bool = False, rest: bool = False):
    """Rows (numpy or torch, raw observations) on the ground within `nudge_max` m of
    the target and nearly still: the nudge law's states. With `flight`, also the slow
    flights there (tilt below FLIGHT_TILT): the micro-flights a nudge ends in, where
    the teacher coasts or holds a plan's attitude, which a network's main branch,
    fitted to millions of other states, gets wrong by a few thousandths of T_max. With
    `rest`, the offset on the ground is `rest_offset`'s instead of the c.m.'s (module
    docstring); they differ by under 0.5 mm on the rows the tilt bound lets in."""
    lib = torch if isinstance(obs, torch.Tensor) else np
    tilt = lib.abs(obs[:, OBS_SIN])
    aloft = observed_mode(obs) == MODE_A
    settled = ~aloft & (tilt < STILL_TILT)
    if flight:
        settled = settled | (aloft & (tilt < FLIGHT_TILT))
    offset = lib.abs(obs[:, OBS_DX]) * POS_SCALE
    if rest:
        offset = lib.where(aloft, offset, lib.abs(rest_offset(obs)))
    return settled & (lib.abs(obs[:, OBS_VX]) * VEL_SCALE < STILL_SPEED) & (offset <= nudge_max)


def at_rest_in_band(obs):
    """Rows (numpy or torch, raw observations) at rest on a face (state F) with a
    contact point in the band, by HOLD_REF: where zero torque is the best action."""
    lib = torch if isinstance(obs, torch.Tensor) else np
    return (observed_mode(obs) == MODE_F) & (lib.abs(obs[:, OBS_REF]) < HOLD_REF)


class Branch(nn.Module):
    """An SB3 actor's deterministic path: normalise (VecNormalize's statistics and
    clip), features, MLP, action head."""

    def __init__(
        self,
        mean,
        var,
        clip: float,
        features: nn.Module,
        mlp: nn.Module,
        head: nn.Module,
        epsilon: float = 1e-8,
    ):
        super().__init__()
        self.register_buffer("mean", torch.as_tensor(np.asarray(mean), dtype=torch.float32))
        self.register_buffer(
            "std", torch.as_tensor(np.sqrt(np.asarray(var) + epsilon), dtype=torch.float32)
        )
        self.clip = float(clip)
        self.features, self.mlp, self.head = features, mlp, head

    def forward(self, obs):
        z = torch.clamp((obs - self.mean) / self.std, -self.clip, self.clip)
        return self.head(self.mlp(self.features(z)))

    @classmethod
    def from_sb3(cls, policy) -> Branch:
        """The deterministic actor of an SB3Policy (hoprover_env.agents.policies)."""
        p = policy.model.policy
        rms = policy.obs_rms
        return cls(
            rms.mean,
            rms.var,
            policy.clip_obs,
            copy.deepcopy(p.features_extractor),
            copy.deepcopy(p.mlp_extractor.policy_net),
            copy.deepcopy(p.action_net),
            policy.epsilon,
        )


class GatedNet(nn.Module):
    """Raw observations (N, 19) -> actions (N, 1) in [-1, 1] (module docstring)."""

    def __init__(
        self,
        main: Branch,
        nudge: Branch,
        deadzone: float = 0.01,
        nudge_max: float = NUDGE_MAX,
        symmetric: bool = False,
        flight: bool = False,
        hold: bool = False,
        rest: bool = False,
    ):
        super().__init__()
        self.main, self.nudge = main, nudge
        self.deadzone, self.nudge_max = float(deadzone), float(nudge_max)
        self.symmetric, self.flight, self.hold = bool(symmetric), bool(flight), bool(hold)
        self.rest = bool(rest)

    def forward(self, obs):
        main, nudge = self.main(obs), self.nudge(obs)
        if self.symmetric:
            # level ground is mirror-symmetric, so each branch acts as the odd part of
            # its fit under the mirror: a fit's error on one side is averaged with its
            # error on the other instead of being flown as it is
            m = mirror(obs)
            main, nudge = 0.5 * (main - self.main(m)), 0.5 * (nudge - self.nudge(m))
        a = torch.where(main.abs() < self.deadzone, torch.zeros_like(main), main)
        gate = near_edge(obs, self.nudge_max, self.flight, self.rest)
        a = torch.where(gate[:, None], nudge, a)
        if self.hold:
            a = torch.where(at_rest_in_band(obs)[:, None], torch.zeros_like(a), a)
        return torch.clamp(a, -1.0, 1.0)


def _spec(branch: Branch) -> dict:
    layers = [m.out_features for m in branch.mlp if isinstance(m, nn.Linear)]
    acts = {type(m).__name__ for m in branch.mlp if not isinstance(m, nn.Linear)}
    return {
        "layers": layers,
        "activation": acts.pop() if acts else "Identity",
        "micro": type(branch.features).__name__ == "MicroStateFeatures",
        "clip": branch.clip,
    }


def _branch(spec: dict, obs_dim: int = 19) -> Branch:
    from gymnasium import spaces
    from stable_baselines3.common.torch_layers import FlattenExtractor

    from research.plan_clone.features import MicroStateFeatures

    space = spaces.Box(-np.inf, np.inf, (obs_dim,), np.float32)
    features = MicroStateFeatures(space) if spec["micro"] else FlattenExtractor(space)
    mods, width = [], features.features_dim
    for n in spec["layers"]:
        mods += [nn.Linear(width, n), getattr(nn, spec["activation"])()]
        width = n
    return Branch(
        np.zeros(obs_dim),
        np.ones(obs_dim),
        spec["clip"],
        features,
        nn.Sequential(*mods),
        nn.Linear(width, 1),
    )


def save(net: GatedNet, path, meta: dict | None = None) -> None:
    """The weights (.pt) and, beside them (.json), the branches' sizes and `meta` (how
    it was made), each written atomically."""
    import io

    from hoprover_env.util.files import atomic_write, write_json

    path = Path(path)
    buf = io.BytesIO()
    torch.save(net.state_dict(), buf)
    atomic_write(path, buf.getvalue())
    write_json(
        path.with_suffix(".json"),
        {
            "kind": "gated",
            "main": _spec(net.main),
            "nudge": _spec(net.nudge),
            "deadzone": net.deadzone,
            "nudge_max": net.nudge_max,
            "symmetric": net.symmetric,
            "flight": net.flight,
            "hold": net.hold,
            "rest": net.rest,
            "env_id": "HopRover-v0",
            "env_kwargs": {"control_dt": 0.5},
            **(meta or {}),
        },
    )


def load(path) -> tuple[GatedNet, dict]:
    """(network, metadata) of a network written by `save`. Raises FileNotFoundError if
    either file is missing and ValueError if the metadata is not a gated network's."""
    path = Path(path)
    meta_path = path.with_suffix(".json")
    for p in (path, meta_path):
        if not p.exists():
            raise FileNotFoundError(f"gated network file missing: {p}")
    meta = json.loads(meta_path.read_text())
    if meta.get("kind") != "gated":
        raise ValueError(
            f"{meta_path} does not describe a gated network (kind {meta.get('kind')!r})"
        )
    net = GatedNet(
        _branch(meta["main"]),
        _branch(meta["nudge"]),
        meta["deadzone"],
        meta["nudge_max"],
        meta.get("symmetric", False),
        meta.get("flight", False),
        meta.get("hold", False),
        meta.get("rest", False),
    )
    net.load_state_dict(torch.load(path, map_location="cpu", weights_only=True))
    net.eval()
    return net, meta


class GatedPolicy:
    """A `GatedNet` acting in HopRover-v0 every `env_kwargs["control_dt"]` s."""

    def __init__(self, net: GatedNet, name: str = "gated", env_kwargs: dict | None = None):
        self.net, self.name = net, name
        self.env_id = "HopRover-v0"
        self.env_kwargs = dict(env_kwargs or {"control_dt": 0.5})

    def reset(self, n: int, first_episode: int = 0) -> None:
        pass

    def act(self, obs: np.ndarray, venv) -> np.ndarray:
        """Deterministic actions (N, 1) for raw observations (N, 19)."""
        with torch.no_grad():
            out = self.net(torch.as_tensor(np.asarray(obs), dtype=torch.float32))
        return out.numpy().astype(np.float64)


def load_policy(path) -> GatedPolicy:
    """The GatedPolicy of a network written by `save` (named after its file)."""
    net, meta = load(path)
    return GatedPolicy(net, name=Path(path).stem, env_kwargs=meta["env_kwargs"])


def load_any(spec: str, **kwargs):
    """A research network's .pt (`load_policy`), or anything the package's
    `hoprover_env.agents.policies.load_policy` loads (a name, a model, a .pt2)."""
    if str(spec).endswith(".pt"):
        return load_policy(spec)
    from hoprover_env.agents.policies import load_policy as load_package_policy

    return load_package_policy(str(spec), **kwargs)


GROUP = "Imitation of a planner"  # the leaderboard's group of a network made here
HOW_MADE = (
    "two networks cloned by least squares and DAgger rounds from the plan-table "
    "teacher, joined by fixed, hand-written parts; no slope input, level ground only"
)
TEACHER = (
    "the plan-table teacher (research/plan_clone/plan_table.py): a table of best-known "
    "plans searched with the simulator from the start state on level ground for a grid "
    "of targets, made alike between neighbours, and a nudge law for targets just beyond "
    "the band's edge (research/plan_clone/nudge.py)"
)


def hand_written(arch: dict) -> list[str]:
    """The fixed (not learned) parts of a gated network with the settings `arch`
    (`nudge_max`, `deadzone`, `symmetric`, `flight`, `hold`, `rest`), in words, with
    their numbers: what the bundled policy's .json lists under "hand_written"."""
    where = f"within {arch['nudge_max']:g} m of the target (`nudge_max`" + (
        "; on the ground measured from the corner it stands on, `rest`)"
        if arch.get("rest")
        else ")"
    )
    gate = (
        f"a fixed gate between the two learned branches on thresholds: the nudge branch "
        f"acts where the rover is {where} and nearly still (tilt below {STILL_TILT:g} rad, "
        f"speed below {STILL_SPEED * 1e3:g} mm/s)"
        + (
            f", or in a slow flight there (tilt below {FLIGHT_TILT:g} rad, `flight`)"
            if arch.get("flight")
            else ""
        )
        + "; the main branch everywhere else"
    )
    parts = [gate]
    if arch.get("hold"):
        parts.append("zero torque forced at rest on a face with a corner in the band (`hold`)")
    if arch.get("symmetric"):
        parts.append(
            "mirror symmetry: each branch acts as the odd part of its fit under "
            "x -> -x (`symmetric`)"
        )
    dz = float(arch.get("deadzone", 0.0))
    parts.append(
        "a dead zone on the main branch's output (`deadzone`: "
        + (f"{dz:g} of T_max)" if dz > 0 else "0 in this network, so it never acts)")
    )
    return parts


def export(net: GatedNet, path, meta: dict) -> None:
    """Write `net` as the package's generic policy file: a torch.export module (.pt2)
    that maps raw observations to actions with the gate, the hold and the mirror inside
    it, and `meta` (with the hand-written parts named) in the file, so that
    `hoprover_env.agents.policies.load_policy` runs it with no code of this module."""
    from hoprover_env.agents.base import TorchPolicy
    from hoprover_env.tasks.observation import OBS_DIM

    arch_keys = ("main", "nudge", "deadzone", "nudge_max", "symmetric", "flight", "hold", "rest")
    arch = {k: meta[k] for k in arch_keys if k in meta}
    meta = {
        **{k: v for k, v in meta.items() if k not in arch_keys},
        "kind": "torch.export",
        "made_by": "imitation of a planner",
        "hand_written": hand_written(arch),
        "architecture": arch,
        "group": GROUP,
        "how_made": HOW_MADE,
        "teacher": TEACHER,
    }
    example = torch.zeros((4, OBS_DIM), dtype=torch.float32)
    TorchPolicy.save(net.eval(), example, path, meta)
    from hoprover_env.util.files import write_json

    write_json(Path(path).with_suffix(".json"), meta)


def main(argv=None) -> int:
    """python -m research.plan_clone.gated export NET.pt OUT.pt2: a saved gated network as
    the package's self-describing policy file."""
    import argparse

    ap = argparse.ArgumentParser(description=main.__doc__)
    sub = ap.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("export", help="a gated network (.pt + .json) as a .pt2 module")
    e.add_argument("net")
    e.add_argument("out")
    args = ap.parse_args(argv)
    net, meta = load(args.net)
    export(net, args.out, meta)
    print(f"wrote {args.out} and {Path(args.out).with_suffix('.json')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
