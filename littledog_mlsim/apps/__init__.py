"""The applications behind the ``littledog-mlsim`` verbs and ``make run``.

They compose the library (``data``, ``models``, ``rollout``, ``diagnose``, ``robot``, ``nodes``)
and own no numerics of their own:

- :mod:`.record` — parallel, atomic dataset recording (``record``);
- :mod:`.evaluate` — TestPool scoring and rollouts of a model file (``evaluate``, ``rollout``);
- :mod:`.reproduce` — the paper's Table I, Fig. 4 and Figs 5-7 (``reproduce``);
- :mod:`.figures`, :mod:`.animate` — the rollout figures and the animation ``reproduce`` draws;
- :mod:`.demo` — ``make run``: both simulators over ROS 2, compared.

The console script's argument parsing lives in :mod:`littledog_mlsim.cli`.
"""
