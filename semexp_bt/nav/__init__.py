"""Navigation: the planner protocol and its implementations, the occupancy map, frontiers and the
path-following maths: the geometry of getting to a subgoal.

May import: ``semexp_bt.core``, numpy and scipy (no behaviour tree, no simulator, no middleware).
"""
