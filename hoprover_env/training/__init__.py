"""Training and distribution: the command lines (`train`, `evaluate`, `sweep`), agents
built from YAML configs (`sb3_agents`), behaviour cloning for warm starts
(`warm_start`; train's `pretrain` section: `pretraining`), Ray (`ray_utils`,
`ray_eval`) and cache warming (`warm_cache`)."""
