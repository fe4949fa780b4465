"""mjflex's native library in C: the per-step math, the engine plugin ``mjflex.flexure`` and the
``mjcb_passive`` dispatcher (``*.c``, ``*.h``), built by ``pip install`` into ``libmjflex-mjNNNNNNN.so``.

Python reaches it through :mod:`mjflex.native.library` (ctypes); ``import mujoco`` loads it through
the top-level module ``mjflex_plugin`` (no Python stack).

Sources
-------
``flexure_math.c``
    The element math (twist and dual quaternion, elastic + viscous, polynomial terms); no MuJoCo.
``elements.c``
    Elements on an ``mjData``: the evaluation loop, the map to generalized forces, the rest
    offset, the per-mjData divergence watch and its reports.
``config.c``
    Parsing and validation of an element's configuration, either form (for a plugin instance a
    compile error on bad input); the constants Python holds too (``mjfx_constant``).
``plugin.c``
    The engine plugin ``mjflex.flexure`` (one instance per element) and its registration.
``instances.c``
    Reading elements from a model, both forms, in one place (``mjfx_read_element``): each
    configuration, the sites, the rest offset and its checks, the dof chains, gathered into the
    table the per-step loop evaluates (the plugin's init, and ``mjfx_read_table`` for Python).
``states.c``
    The registry of the plugin's per-mjData states: the plugin never trusts ``mjData.plugin_data``
    (pickled datas, rollout with other models; see plugin.c and docs/background/known_issues.md).
``callback.c``
    The ``mjcb_passive`` dispatcher and the registry of the text-record models it serves.
``api.c``
    Entry points for Python: the element struct's layout, the element table, configuration
    checks, the shared constants, batch math for the tests.

Python's side is :mod:`mjflex.native.library` (the bindings; this package holds no other Python).
"""
