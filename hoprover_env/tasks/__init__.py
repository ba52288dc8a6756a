"""The RL tasks over the physics core: what an action does, what a step returns.

=================  ==================================================================
``common``         the written interface (`TaskSpec`), the opening and end of every
                   step (`open_step`, `close_step`), the batched loops, `build`
``layout``         the task configuration vector E (one slot each)
``observation``    the observation vector (one slot each), observe, the reference and
                   landing points the observation and the reward share
``torque``         the torque task: action -> torque held for one control period
``hop``            the hop-level task: action -> one hop flown by a built-in controller
``terrain``        the torque task on sloped, rough ground: its step, the observation
                   plus the slope
``mission``        the torque task under mission conditions: noisy sensing, position
                   fixes only at rest, unknown ground, an actuator scale error
=================  ==================================================================

A new task is one module that defines ``TASK = TaskSpec(...)`` (its step template
calling ``ADVANCE``, its observe and config); its env module subclasses HopRoverEnv and
HopRoverVectorEnv with ``task = TASK``; hoprover_env/__init__.py registers its id.
docs/ARCHITECTURE.md walks through one.
"""
