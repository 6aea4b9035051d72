"""semexp-bt: decision-driven semantic object exploration for legged robots, as a py_trees executive."""

__version__ = "0.1.0"
