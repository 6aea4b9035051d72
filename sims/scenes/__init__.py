"""Procedural scene builders: one module per scene, data in ``data/<scene>.yaml``; see :mod:`sims.catalogue`."""
