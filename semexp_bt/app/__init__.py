"""The application: the mission runner for any ``Robot``, the simulated episode built on top of it,
the one place that builds robot, perception, relevance and planner by name from configuration,
strategies as data, and the recorder.

May import: everything below it (``sims``, ``trees``, ``behaviours``, ``blackboard``, ``robots``,
``semexp_bt.perception``, ``semexp_bt.nav``, ``semexp_bt.core``); never ``semexp_bt.bench`` or
``semexp_bt.cli``.
"""
