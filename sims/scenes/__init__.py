"""The scenes as data: ``catalogue.yaml`` lists them, ``data/<scene>.yaml`` holds each layout, and
:mod:`sims.scenes.placement` builds a :class:`~semexp_bt.core.scene.SceneSpec` from data and a seed."""
