"""The browser view of a mission: the tree, the robot's world and the memory, live and replayed.

- :mod:`~semexp_bt.app.viewer.observer`: the view as a tick observer (bounded queue, worker thread).
- :mod:`~semexp_bt.app.viewer.frames`: what a world frame holds (plain data, light to import).
- :mod:`~semexp_bt.app.viewer.capture`: the tick thread's capture of a frame per tick with news.
- :mod:`~semexp_bt.app.viewer.maps`: the one adapter from the planner's map to a drawable grid.
- :mod:`~semexp_bt.app.viewer.world`: the world through Rerun (entity paths, blueprint, explanation).
- :mod:`~semexp_bt.app.viewer.tree_page`: the tree page and its local HTTP server.
- :mod:`~semexp_bt.app.viewer.recording`: the saved recording's directory format.
- :mod:`~semexp_bt.app.viewer.mcap_export`: a saved recording as an MCAP file of ROS 2 messages.

Rerun, its web viewer and the MCAP libraries are the ``viewer`` extra; they are imported only by the
modules that use them, when they are used. See docs/viewer.md.
"""
