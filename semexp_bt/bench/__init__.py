"""Benchmarks and sweeps: sweep specs and keys, result rows, executors (process pool, Ray), the paper
protocol, reports, sweep comparison, and the core and tree benchmarks.

May import: ``semexp_bt.app`` and everything below it; never ``semexp_bt.cli``.
"""
