"""SceneSpec -> MJCF: floor, walls and objects, lighting, and the Go1 in one of two fidelities.

- ``dynamic``: the full Go1 of ``robots/go1/go1.xml`` on a free joint, 12 position actuators and the IMU.
- ``kinematic``: the Go1 trunk collision shape (trunk and head boxes), a box that bounds the legs in the
  standing pose, the IMU site and the head camera, on a planar base (slide x, slide y, hinge yaw) at the
  settled standing height. The backend sets its qpos from the integrated twist and checks distances
  itself, so its geoms take no part in MuJoCo's collision detection (contype = conaffinity = 0).

Scene geoms are static (children of the world body, no extra bodies) so that ``mj_step`` stays cheap.
Every geom of scene object ``k`` is named ``obj{k}_{i}`` (``i`` = 0 for the main shape, 1.. for its
parts): :func:`geom_object_ids` reads the ids back from the names for segmentation and contact events.

Collision bits: robot geoms have contype 4, conaffinity 0; the floor and obstacles have contype 0,
conaffinity 4. So the dynamic robot touches the floor and obstacles, nothing touches itself, and static
geoms never test each other.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import numpy.typing as npt

from robots.camera import CameraConfig
from robots.go1 import (
    CAMERA_NAME,
    GO1_XML_PATH,
    IMU_SITE_NAME,
    TRUNK_BODY_NAME,
    Go1Spec,
    leg_envelope,
    load_go1_spec,
)
from robots.interface import FIDELITIES, Fidelity
from semexp_bt.core.scene import SceneObject, SceneSpec
from semexp_bt.core.types import BACKGROUND_OBJECT_ID

FLOOR_GEOM_NAME = "floor"
KINEMATIC_JOINT_NAMES: tuple[str, str, str] = ("base_x", "base_y", "base_yaw")
LEG_ENVELOPE_GEOM_NAME = "legs_envelope"

#: Collision bit shared by the robot (contype) and everything it may touch (conaffinity).
ROBOT_COLLISION_BIT = 4

#: How far the floor extends beyond the scene bounds (m): beyond the camera's 10 m range.
FLOOR_MARGIN_M = 15.0

_OBJECT_GEOM_NAME = re.compile(r"^obj(\d+)_(\d+)$")
_SHAPES = ("box", "cylinder")


def object_geom_name(object_id: int, index: int) -> str:
    """Name of geom ``index`` (0 = main shape) of scene object ``object_id``."""
    return f"obj{object_id}_{index}"


def object_id_from_geom_name(name: str | None) -> int | None:
    """The scene object id encoded in a geom name, or None for the floor, the robot and unnamed geoms."""
    if not name:
        return None
    match = _OBJECT_GEOM_NAME.match(name)
    return int(match.group(1)) if match else None


def geom_object_ids(model: mujoco.MjModel) -> npt.NDArray[np.int32]:
    """``(ngeom,)`` scene object id per geom, ``BACKGROUND_OBJECT_ID`` for every other geom."""
    ids = np.full(model.ngeom, BACKGROUND_OBJECT_ID, dtype=np.int32)
    for geom_id in range(model.ngeom):
        object_id = object_id_from_geom_name(model.geom(geom_id).name)
        if object_id is not None:
            ids[geom_id] = object_id
    return ids


def robot_geom_ids(model: mujoco.MjModel) -> npt.NDArray[np.int32]:
    """Ids of the geoms on the robot (the trunk body and its descendants)."""
    trunk = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, TRUNK_BODY_NAME)
    if trunk < 0:
        raise ValueError(f"model has no body named '{TRUNK_BODY_NAME}'")
    on_robot = [g for g in range(model.ngeom) if _is_descendant(model, int(model.geom_bodyid[g]), trunk)]
    return np.array(on_robot, dtype=np.int32)


def _is_descendant(model: mujoco.MjModel, body: int, ancestor: int) -> bool:
    while body > 0:
        if body == ancestor:
            return True
        body = int(model.body_parentid[body])
    return body == ancestor


def _fmt(values: object) -> str:
    return " ".join(f"{float(v):.6g}" for v in values)  # type: ignore[attr-defined]


def _fmt_exact(values: object) -> str:
    """Every bit of each float (``repr``): the camera's pose must be its configuration's, which the
    backends report as the frame's pose (6 digits put the optical axis 2e-7 rad off)."""
    return " ".join(repr(float(v)) for v in values)  # type: ignore[attr-defined]


def _yaw_quat(yaw_rad: float) -> tuple[float, float, float, float]:
    return (math.cos(yaw_rad / 2.0), 0.0, 0.0, math.sin(yaw_rad / 2.0))


def _shape_size(shape: str, size: tuple[float, float, float], where: str) -> tuple[float, ...]:
    if shape not in _SHAPES:
        raise ValueError(f"{where}: shape must be one of {_SHAPES}, got {shape!r}")
    if not all(math.isfinite(s) and s > 0 for s in size):
        raise ValueError(f"{where}: size must be three positive finite numbers, got {size!r}")
    return tuple(size) if shape == "box" else (size[0], size[2])


def _object_geoms(obj: SceneObject) -> list[ET.Element]:
    """The object's main geom and its parts, in world coordinates."""
    where = f"scene object {obj.object_id} ('{obj.name}')"
    if obj.object_id < 0:
        raise ValueError(f"{where}: object_id must be non-negative")
    if len(obj.position_m) != 3 or not all(math.isfinite(v) for v in obj.position_m):
        raise ValueError(f"{where}: position_m must be three finite numbers, got {obj.position_m!r}")
    if not math.isfinite(obj.yaw_rad):
        raise ValueError(f"{where}: yaw_rad must be finite, got {obj.yaw_rad!r}")
    affinity = str(ROBOT_COLLISION_BIT if obj.is_obstacle else 0)  # non-obstacles (rugs) touch nothing
    quat = _fmt(_yaw_quat(obj.yaw_rad))
    geoms = [
        ET.Element(
            "geom",
            name=object_geom_name(obj.object_id, 0),
            type=obj.shape,
            size=_fmt(_shape_size(obj.shape, obj.size_m, where)),
            pos=_fmt(obj.position_m),
            quat=quat,
            rgba=_fmt(obj.rgba),
            contype="0",
            conaffinity=affinity,
        )
    ]
    cos_yaw, sin_yaw = math.cos(obj.yaw_rad), math.sin(obj.yaw_rad)
    for index, part in enumerate(obj.parts, start=1):
        if len(part) != 11:
            raise ValueError(f"{where}: part {index} must be (shape, dx, dy, dz, sx, sy, sz, r, g, b, a)")
        shape = str(part[0])
        dx, dy, dz, sx, sy, sz, red, green, blue, alpha = (float(v) for v in part[1:])  # type: ignore[arg-type]
        position = (
            obj.position_m[0] + cos_yaw * dx - sin_yaw * dy,
            obj.position_m[1] + sin_yaw * dx + cos_yaw * dy,
            obj.position_m[2] + dz,
        )
        geoms.append(
            ET.Element(
                "geom",
                name=object_geom_name(obj.object_id, index),
                type=shape,
                size=_fmt(_shape_size(shape, (sx, sy, sz), f"{where} part {index}")),
                pos=_fmt(position),
                quat=quat,
                rgba=_fmt((red, green, blue, alpha)),
                contype="0",
                conaffinity=affinity,
            )
        )
    return geoms


def _configure_camera(body: ET.Element, camera: CameraConfig) -> None:
    element = body.find(f"camera[@name='{CAMERA_NAME}']")
    if element is None:
        raise ValueError(f"{GO1_XML_PATH}: trunk has no camera named '{CAMERA_NAME}'")
    element.set("pos", _fmt_exact(camera.mount_position_m))
    element.set("xyaxes", _fmt_exact(camera.mujoco_xyaxes()))
    element.set("fovy", f"{camera.vertical_fov_deg:.6g}")


def _kinematic_trunk(trunk: ET.Element, spec: Go1Spec) -> ET.Element:
    """The planar-base body: trunk geoms, leg envelope, IMU site and camera; no legs."""
    height = spec.standing_trunk_height_m
    body = ET.Element("body", name=TRUNK_BODY_NAME, pos=_fmt((0.0, 0.0, height)), childclass="go1")
    for name, axis, kind in zip(
        KINEMATIC_JOINT_NAMES, ("1 0 0", "0 1 0", "0 0 1"), ("slide", "slide", "hinge"), strict=True
    ):
        ET.SubElement(
            body,
            "joint",
            name=name,
            type=kind,
            axis=axis,
            limited="false",
            damping="0",
            armature="0",
            frictionloss="0",
        )
    inertial = trunk.find("inertial")
    if inertial is not None:
        body.append(inertial)
    no_collision = {"contype": "0", "conaffinity": "0"}
    for child in trunk:
        if child.tag == "geom":
            child.attrib.update(no_collision)
            body.append(child)
        elif child.tag in ("site", "camera"):
            body.append(child)
    centre, half = leg_envelope(spec, height)
    ET.SubElement(
        body,
        "geom",
        name=LEG_ENVELOPE_GEOM_NAME,
        type="box",
        pos=_fmt(centre),
        size=_fmt(half),
        rgba="0.2 0.2 0.22 1",
        contype="0",
        conaffinity="0",
    )
    if body.find(f"site[@name='{IMU_SITE_NAME}']") is None:
        raise ValueError(f"{GO1_XML_PATH}: trunk has no site named '{IMU_SITE_NAME}'")
    return body


def build_mjcf(scene: SceneSpec, *, fidelity: Fidelity, camera: CameraConfig | None = None) -> str:
    """The MJCF text of ``scene`` with the Go1 at the origin (the backend places it).

    Args:
        scene: floor colour, bounds and objects.
        fidelity: ``"dynamic"`` (legged Go1 on a free joint) or ``"kinematic"`` (planar base).
        camera: head camera mount and field of view; the default :class:`CameraConfig` when None.

    Raises:
        ValueError: on an unknown fidelity, a malformed object (naming it) or duplicate object ids.
    """
    if fidelity not in FIDELITIES:
        raise ValueError(f"fidelity must be one of {FIDELITIES}, got {fidelity!r}")
    camera = camera or CameraConfig()
    spec = load_go1_spec()
    ids = [obj.object_id for obj in scene.objects]
    if len(ids) != len(set(ids)):
        raise ValueError(
            f"scene '{scene.name}': duplicate object ids {sorted(i for i in ids if ids.count(i) > 1)}"
        )
    x_min, y_min, x_max, y_max = scene.bounds_m
    if not (x_min < x_max and y_min < y_max) or not all(math.isfinite(v) for v in scene.bounds_m):
        raise ValueError(
            f"scene '{scene.name}': bounds_m must be (x_min, y_min, x_max, y_max), got {scene.bounds_m}"
        )

    robot = ET.parse(GO1_XML_PATH).getroot()
    root = ET.Element("mujoco", model=f"semexp_{scene.name}_{fidelity}")
    for tag in ("compiler", "option", "default"):
        element = robot.find(tag)
        if element is not None:
            root.append(element)

    if scene.outdoor:
        # A gradient sky instead of the black clear colour; indoor scenes have walls all round.
        asset = ET.SubElement(root, "asset")
        ET.SubElement(
            asset,
            "texture",
            name="sky",
            type="skybox",
            builtin="gradient",
            rgb1="0.55 0.7 0.9",
            rgb2="0.85 0.9 0.95",
            width="64",
            height="64",
        )

    visual = ET.SubElement(root, "visual")
    # The offscreen buffer is the head camera's render size: the software rasteriser spends time on a
    # larger buffer's pixels (clearing them) that no pass draws or reads.
    ET.SubElement(visual, "global", offwidth=str(camera.width_px), offheight=str(camera.height_px))
    # offsamples=0: no multisampling (it would blend segmentation ids at edges and costs the software
    # rasteriser most); shadowsize=0: no shadow map.
    ET.SubElement(visual, "quality", shadowsize="0", offsamples="0")
    ET.SubElement(visual, "headlight", ambient="0.35 0.35 0.35", diffuse="0.45 0.45 0.45", specular="0 0 0")

    world = ET.SubElement(root, "worldbody")
    ET.SubElement(
        world,
        "light",
        name="sun",
        directional="true",
        pos="0 0 6",
        dir="0.3 0.2 -1",
        diffuse="0.5 0.5 0.5",
        specular="0 0 0",
        castshadow="false",
    )
    floor_centre = ((x_min + x_max) / 2.0, (y_min + y_max) / 2.0, 0.0)
    floor_half = ((x_max - x_min) / 2.0 + FLOOR_MARGIN_M, (y_max - y_min) / 2.0 + FLOOR_MARGIN_M, 0.05)
    ET.SubElement(
        world,
        "geom",
        name=FLOOR_GEOM_NAME,
        type="plane",
        pos=_fmt(floor_centre),
        size=_fmt(floor_half),
        rgba=_fmt(scene.floor_rgba),
        contype="0",
        conaffinity=str(ROBOT_COLLISION_BIT),
        friction="1 0.005 0.0001",
    )
    for obj in scene.objects:
        world.extend(_object_geoms(obj))

    trunk = robot.find(f"worldbody/body[@name='{TRUNK_BODY_NAME}']")
    if trunk is None:
        raise ValueError(f"{GO1_XML_PATH}: no body named '{TRUNK_BODY_NAME}'")
    _configure_camera(trunk, camera)
    if fidelity == "dynamic":
        world.append(trunk)
        for tag in ("actuator", "sensor", "keyframe"):
            element = robot.find(tag)
            if element is not None:
                root.append(element)
    else:
        world.append(_kinematic_trunk(trunk, spec))
    return ET.tostring(root, encoding="unicode")
