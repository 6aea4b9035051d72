"""The paper's maths: types, configuration, geometry, the scene spec, evidence arbitration (Eq. 1-4),
the topological memory (Eq. 5-7), the subgoal decision and its baselines (Eq. 8-10), the relevance
protocol with the lexical scorer, the metrics (SR, SPL, OASR, SA, GNSA), and result files written whole
or not at all (``durable``).

May import: numpy, scipy, networkx and the standard library only (pyproject.toml's import contracts
check it), so that the method stays testable and benchmarkable without a robot, a simulator or a model.
"""
