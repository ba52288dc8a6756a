"""Evaluation: judged episodes of any policy (`episodes`: `run_episodes`,
`seeded_targets`, `summarize`), the frozen suites and their best-known references
(`suites`), normalised scores with intervals (`scores`), replay for figures and
videos (`replay`, `plots`) and offline-RL datasets (`datasets`).

`hoprover_env.evaluation.run_episodes` and the other names of `episodes` are
importable from here, as they were when evaluation was one module.
"""

from hoprover_env.evaluation.episodes import (
    EpisodeResult,
    run_episodes,
    seeded_targets,
    summarize,
    venv_final_x,
)

__all__ = ["EpisodeResult", "run_episodes", "seeded_targets", "summarize", "venv_final_x"]
