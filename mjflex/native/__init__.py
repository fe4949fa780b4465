"""mjflex's native library in C: the per-step math, the engine plugin ``mjflex.flexure`` and the
``mjcb_passive`` dispatcher (``*.c``, ``*.h``), built by ``pip install`` into ``libmjflex-mjNNNNNNN.so``.

Python reaches it through :mod:`mjflex.mj._native` (ctypes); ``import mujoco`` loads it through
the top-level module ``mjflex_plugin`` (no Python stack).

Sources
-------
``flexure_math.c``
    The element math (twist and dual quaternion, elastic + viscous, polynomial terms); no MuJoCo.
``elements.c``
    Elements on an ``mjData``: the evaluation loop, the map to generalized forces, the rest
    offset, the per-mjData divergence watch and its reports.
``config.c``
    Parsing and validation of a plugin instance's configuration (a compile error on bad input).
``plugin.c``
    The engine plugin ``mjflex.flexure`` (one instance per element) and its registration.
``instances.c``
    Reading the plugin's elements from a model: each instance's configuration, sites, rest offset
    and dof chains, gathered into the table the per-step loop evaluates.
``states.c``
    The registry of the plugin's per-mjData states: the plugin never trusts ``mjData.plugin_data``
    (pickled datas, rollout with other models; see plugin.c and docs/background/known_issues.md).
``callback.c``
    The ``mjcb_passive`` dispatcher and the registry of the text-record models it serves.
``api.c``
    Entry points for Python: the element struct's layout, batch math for the tests.
"""
