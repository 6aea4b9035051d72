"""Benchmarks and sweeps, one concept per module: ``sweep`` (specs, keys, the config hash), ``rows``
(a row's content), ``store`` (a sweep folder's files, written so that a kill loses nothing finished),
``worker`` (one episode inside a worker), ``executors`` (in-process, process pool, Ray), ``progress``,
``engine`` (``run_sweep``), ``protocol`` (the paper's grids), ``stats``, ``markdown``, ``plots``,
``report`` and ``paper_results`` (what a sweep's rows say), ``compare`` (two sweeps), and the ``core``
and ``tree`` benchmarks. docs/harness.md describes them.

May import: ``semexp_bt.app`` and everything below it; never ``semexp_bt.cli``.
"""
