"""Environment pages from the env modules' docstrings (a Sphinx extension).

An environment page is a small Markdown file in docs/envs/ with one block

    ```{hoprover-env} HopRover-v0
    :policy: scratch
    :target: 0.7
    ```

which this extension replaces, before MyST parses the page, with: a summary table (how
to make the env, its classes, spaces and fixed arguments, read from the registered env
itself), an animation of the bundled `policy` on `target` [m] (made at build time by
docs/_ext/animations.py; HopRoverContest-v0 always uses its fixed target), and the env
module's docstring (its Markdown sections: description, action and observation spaces,
rewards, start, end, arguments), i.e. its task module's (hoprover_env/tasks/*.py).
Adding an environment = adding its task (docs/ARCHITECTURE.md): a registered id of the
package without a page of its own gets one written at the start of the build
(docs/envs/generated-ID.md, ignored by git: its title and the block, so the whole page
is the module's); a page of its own (ID.md) adds an introduction and the animation's
policy and target. The toctree of docs/envs/index.md globs both.
"""

from __future__ import annotations

import importlib
import inspect
import json
import re
from pathlib import Path

from sphinx.util import logging

logger = logging.getLogger(__name__)
BLOCK = re.compile(
    r"^```\{hoprover-env\}[ \t]+(?P<id>\S+)[ \t]*\n(?P<opts>(?::[\w-]+:.*\n)*)```"
    r"[ \t]*$",
    re.M,
)
ANIM_DIR = "_generated/anim"


def _blocks(text: str):
    for m in BLOCK.finditer(text):
        opts = dict(re.findall(r"^:([\w-]+):[ \t]*(.*)$", m.group("opts"), re.M))
        unknown = set(opts) - {"policy", "target"}
        if unknown:
            raise ValueError(
                f"{{hoprover-env}} {m.group('id')}: unknown option(s) "
                f"{sorted(unknown)}; valid: policy, target"
            )
        yield m, m.group("id"), opts


def _sources_newer(gif: Path, root: Path) -> bool:
    """Whether any simulator, agent or bundled-policy file changed after `gif` was made."""
    made = gif.stat().st_mtime
    files = [
        *root.glob("hoprover_env/**/*.py"),
        *root.glob("research/*.py"),
        *root.glob("hoprover_env/agents/policies/*"),
    ]
    return any(f.stat().st_mtime > made for f in files)


def make_animations(app) -> None:
    """builder-inited: the GIF of every env page, unless one newer than the code exists."""
    from animations import make_animation

    src = Path(app.srcdir)
    root = src.parent
    for page in sorted((src / "envs").glob("*.md")):
        for _, env_id, opts in _blocks(page.read_text()):
            if "policy" not in opts:
                continue
            gif = src / ANIM_DIR / f"{env_id}.gif"
            if gif.exists() and gif.with_suffix(".json").exists() and not _sources_newer(gif, root):
                continue
            meta = make_animation(env_id, opts["policy"], float(opts.get("target", 0.7)), gif)
            logger.info(f"[envpages] {env_id}: {meta}")


def _space(space) -> str:
    shape, dtype = space.shape, space.dtype
    lo, hi = float(space.low.min()), float(space.high.max())
    return f"`Box({lo:g}, {hi:g}, {shape}, {dtype})`"


def env_markdown(env_id: str, opts: dict, srcdir: Path) -> str:
    """The Markdown that replaces one {hoprover-env} block."""
    import gymnasium as gym

    import hoprover_env

    if env_id not in hoprover_env.ENVS:
        raise ValueError(
            f"{{hoprover-env}}: {env_id!r} is not a hoprover env id; "
            f"registered: {sorted(hoprover_env.ENVS)}"
        )
    spec = hoprover_env.ENVS[env_id]
    entry, vector_entry, fixed = spec.env, spec.vector_env, spec.kwargs
    module_name, cls_name = entry.split(":")
    vmodule, vcls = vector_entry.split(":")
    module = importlib.import_module(spec.module)  # the task module: the env's docs
    env = gym.make(env_id)
    obs_space, act_space = env.observation_space, env.action_space
    env.close()
    doc = inspect.cleandoc(module.__doc__ or "")
    title, _, body = doc.partition("\n")
    fixed_text = ", ".join(f"`{k}={v!r}`" for k, v in fixed.items()) or "none"
    lines = [
        f"*{title.strip()}*",
        "",
        "| | |",
        "|---|---|",
        f'| Make | `gym.make("{env_id}")` (after `import hoprover_env`) |',
        f'| Vector env | `gym.make_vec("{env_id}", num_envs=N)`: {{py:class}}`~{vmodule}.{vcls}` |',
        f"| Env class | {{py:class}}`~{module_name}.{cls_name}` |",
        f"| Fixed arguments | {fixed_text} |",
        f"| Action space | {_space(act_space)} |",
        f"| Observation space | {_space(obs_space)} (bounds per component below) |",
        f"| Source | `{spec.module.replace('.', '/')}.py` (this page is its docstring) |",
        "",
    ]
    gif = srcdir / ANIM_DIR / f"{env_id}.gif"
    if "policy" in opts and gif.with_suffix(".json").exists():
        meta = json.loads(gif.with_suffix(".json").read_text())
        verdict = (
            f"TTRTP {meta['ttrtp']:.1f} s"
            if meta["ttrtp"] is not None
            else ("broke" if meta["broken"] else "target not reached")
        )
        lines += [
            f":::{{figure}} /{ANIM_DIR}/{env_id}.gif",
            f":alt: the bundled {meta['policy']} policy on {env_id}",
            ":width: 100%",
            "",
            f"The bundled `{meta['policy']}` policy on `{env_id}`, target "
            f"{meta['target_x']:+.2f} m: {verdict} by the contest judge. Rendered during "
            "the build from this run (the GIF of `evaluate.py --video`); the time in the "
            "corner is simulated time, sped up."
            + (
                " Left: the true rover; right: the rover as the policy's estimator sees "
                "it (the last fix, the attitude estimate, the contact state it reads from "
                "the gyro)."
                if "sides" in meta
                else ""
            ),
            ":::",
            "",
        ]
    lines.append(body.strip())
    return "\n".join(lines) + "\n"


def source_read(app, docname: str, source: list) -> None:
    text = source[0]
    if "{hoprover-env}" not in text:
        return
    out, last = [], 0
    for m, env_id, opts in _blocks(text):
        out += [text[last : m.start()], env_markdown(env_id, opts, Path(app.srcdir))]
        last = m.end()
    source[0] = "".join(out) + text[last:]


GENERATED = "generated-{}.md"


def write_missing_pages(app) -> None:
    """A page for every id the package registers that has none of its own (see the
    module docstring); stale generated pages are removed."""
    from hoprover_env.envs.registry import ENVS

    envs = Path(app.srcdir) / "envs"
    want = {
        GENERATED.format(env_id): env_id
        for env_id, spec in ENVS.items()
        if spec.module.startswith("hoprover_env.") and not (envs / f"{env_id}.md").exists()
    }
    for old in envs.glob(GENERATED.format("*")):
        if old.name not in want:
            old.unlink()
    for name, env_id in want.items():
        text = f"# {env_id}\n\n```{{hoprover-env}} {env_id}\n```\n"
        path = envs / name
        if not path.exists() or path.read_text() != text:
            path.write_text(text)


def setup(app):
    app.connect("builder-inited", write_missing_pages)
    app.connect("builder-inited", make_animations)
    app.connect("source-read", source_read)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
