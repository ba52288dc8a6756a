"""Gymnasium environments over the tasks: the single env (`env`), the native vector env
(`vector_env`), what both share (`parts`), each task's env classes, rendering, and the
Stable-Baselines3 and RLlib adapters (`sb3`, `rllib`)."""
