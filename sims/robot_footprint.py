"""The robot's planar footprint, named once for the occupancy grid, the oracle and the scene checks.

The Unitree Go1 trunk is about 0.38 m x 0.09 m, but the legs splay to roughly 0.60 m x 0.30 m at the
feet while walking, and the base rotates in place during the panoramic init. A disc that covers the
feet in any heading has a radius of about 0.30 m, so every free cell of the inflated grid is a place
where the base centre can stand in any yaw without touching an obstacle.
"""

from __future__ import annotations

#: Radius (m) of the disc that covers the Go1's feet in any heading; obstacles are inflated by it.
ROBOT_RADIUS_M = 0.30

#: Height (m) below which geometry blocks the robot: Go1 standing height (~0.40 m) plus the head
#: camera mount. Parts of an object that start above it (a sign plate, a bus-shelter roof, a tree
#: canopy) are walked under and are not rasterised into the occupancy grid.
ROBOT_CLEARANCE_HEIGHT_M = 0.50

#: Least distance (m) from a sampled start position to any obstacle: the kinematic body's half-diagonal
#: (0.65 m x 0.30 m box, 0.36 m) plus the 0.1 m clearance of OASR, so that no episode starts in contact
#: or already breaching the clearance, whatever its start yaw.
START_CLEARANCE_M = 0.46
