"""Agents that act in hoprover's tasks: the scripted hopper, the contest controllers
compiled with numba, the `mpc` planner and its hop plans, the mission task's state
estimator and hop policy, and the policy registry with the bundled weights
(`policies`)."""
