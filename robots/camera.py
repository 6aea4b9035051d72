"""A RealSense-D435i-like head RGB-D camera rendered offscreen with MuJoCo.

The D435i colour stream at 640x480 has fx = fy of about 615 px, i.e. a 42.5 deg vertical and 55 deg
horizontal field of view (the 69 x 42 deg of the data sheet is the 16:9 1920x1080 mode; 4:3 crops the
sides). Depth is aligned to colour and valid from 0.3 m to 10 m; anything outside reads 0, as
``rs2::align`` gives for no return. Depth comes in whole millimetres, as the D435i's 16UC1 stream (and
the ROS 2 bridge, which publishes that stream) carries it: the mission sees the same depth in process and
over ROS 2, to the bit (``robots.ros2_messages.round_depth_to_millimetres``).

Rendering runs at the native size divided by ``CameraConfig.downscale`` (default 2: 320x240) and the
intrinsics scale with it. One ``observe`` is two GL passes: a lit colour pass whose depth buffer is read
in the same ``mjr_readPixels`` call, and a flat-colour segmentation pass (``mjRND_SEGMENT`` and
``mjRND_IDCOLOR``). A depth-only render (the local planner's, at 12 Hz) is one flat-colour pass.
Shadows, reflections, haze, fog and multisampling are off (and the skybox unless the scene is outdoor):
they cost the software (llvmpipe) rasteriser time and a detector emulator does not need them.

Depth: MuJoCo's offscreen depth buffer is reversed-Z (``mjDEPTH_ZEROFAR``: 1 at the near plane, 0 at
the far plane). For a perspective projection with near n and far f, a window depth ``z_w`` maps to the
eye-space distance along the optical axis ``z = n f / (n + z_w (f - n))``: it is depth along the axis
(what a RealSense reports), not the Euclidean range along the ray.
"""

from __future__ import annotations

import functools
import math
import os
import platform
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np
import numpy.typing as npt

from robots.mount import optical_to_base
from robots.ros2_messages import round_depth_to_millimetres
from semexp_bt.core.types import (
    BACKGROUND_OBJECT_ID,
    CameraIntrinsics,
    FloatArray,
    InvalidInputError,
    PixelGrid,
)

#: MuJoCo cameras look along -z with +y up; the optical frame looks along +z with +y down.
MUJOCO_TO_OPTICAL = np.diag([1.0, -1.0, -1.0])

#: Clip planes (m). The near plane sits well inside the 0.3 m minimum range, the far plane beyond 10 m.
NEAR_CLIP_M = 0.02
FAR_CLIP_M = 50.0

#: Scene flags that are switched off for speed. The skybox stays on only in models that define one
#: (outdoor scenes): a 64x64 gradient cube costs little, and the sky reads as background and depth 0.
_SLOW_RENDER_FLAGS = (
    mujoco.mjtRndFlag.mjRND_SHADOW,
    mujoco.mjtRndFlag.mjRND_REFLECTION,
    mujoco.mjtRndFlag.mjRND_HAZE,
    mujoco.mjtRndFlag.mjRND_FOG,
)


class PixelRays(NamedTuple):
    """The camera-fixed part of casting rays at a set of pixels, computed once per set."""

    rows: npt.NDArray[np.intp]
    cols: npt.NDArray[np.intp]
    directions_optical: FloatArray
    """Unit ray directions in the optical frame, ``(N, 3)``."""
    depth_per_range: FloatArray
    """Optical-axis depth per metre along each ray."""
    cutoff_m: float
    """Range beyond which no ray can return a valid depth."""


@functools.lru_cache(maxsize=32)
def pixel_rays(
    intrinsics: CameraIntrinsics,
    *,
    height_px: int,
    width_px: int,
    pixel_grids: tuple[PixelGrid, ...],
    max_depth_m: float,
) -> PixelRays:
    """The optical-frame rays through the union of the grids' pixels of a pinhole camera, computed once
    per camera and set of grids (cached: every depth read of a grid reuses them, read-only)."""
    sampled = np.zeros((height_px, width_px), dtype=bool)
    for grid in pixel_grids:
        sampled |= grid.mask(height_px=height_px, width_px=width_px)
    rows, cols = np.nonzero(sampled)
    k = intrinsics
    directions = np.stack(
        [(cols - k.cx_px) / k.fx_px, (rows - k.cy_px) / k.fy_px, np.ones(rows.shape[0])], axis=1
    )
    norms = np.linalg.norm(directions, axis=1)
    depth_per_range = 1.0 / norms
    # The most oblique ray reaches max_depth_m along the axis at the longest range.
    cutoff_m = max_depth_m / float(depth_per_range.min()) if norms.size else 0.0
    rays = PixelRays(rows, cols, directions / norms[:, None], depth_per_range, cutoff_m)
    for array in rays[:4]:
        array.flags.writeable = False  # shared by every caller of the cache
    return rays


def cast_depth(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    rays: PixelRays,
    *,
    origin_m: FloatArray,
    optical_to_world: FloatArray,
    geomgroup: npt.NDArray[np.uint8],
    exclude_body_id: int,
    depth_range_m: tuple[float, float],
    shape: tuple[int, int],
    invalid_geoms: npt.NDArray[np.int32] | None = None,
) -> npt.NDArray[np.float32]:
    """Depth along the optical axis at the rays' pixels (``mj_multiRay``), in whole millimetres; NaN at
    pixels without a ray; 0 where nothing is hit within range, or where the hit geom is one of
    ``invalid_geoms`` (the robot's own legs, which a real depth camera masks out)."""
    directions = np.ascontiguousarray(rays.directions_optical @ optical_to_world.T).ravel()
    count = rays.rows.shape[0]
    geom_ids = np.empty(count, dtype=np.int32)
    ranges = np.empty(count, dtype=np.float64)
    if count:
        mujoco.mj_multiRay(
            model,
            data,
            np.array(origin_m, dtype=np.float64),
            directions,
            geomgroup,
            1,
            exclude_body_id,
            geom_ids,
            ranges,
            None,
            count,
            rays.cutoff_m,
        )
    depth_along_axis = ranges * rays.depth_per_range
    low, high = depth_range_m
    valid = (ranges >= 0.0) & (depth_along_axis >= low) & (depth_along_axis <= high)
    if invalid_geoms is not None and invalid_geoms.size:
        valid &= ~np.isin(geom_ids, invalid_geoms)
    depth = np.full(shape, np.nan, dtype=np.float32)
    depth[rays.rows, rays.cols] = np.where(valid, depth_along_axis, 0.0)
    return round_depth_to_millimetres(depth)


@dataclass(frozen=True)
class CameraConfig:
    """The head camera: image size, field of view, depth range and mount on the trunk.

    Attributes:
        native_width_px: sensor stream width (D435i colour at 640x480).
        native_height_px: sensor stream height.
        downscale: integer divisor of the native size used for rendering (1 = native).
        vertical_fov_deg: vertical field of view of the colour stream.
        min_depth_m: depth below this reads 0 (D435i minimum range at 640x480).
        max_depth_m: depth beyond this reads 0.
        mount_position_m: camera centre in the trunk frame (x forward, y left, z up): on the front
            sensor housing, 0.28 m ahead of and 0.05 m above the trunk centre.
        mount_pitch_down_deg: downward pitch of the optical axis: with the default FoV the floor from
            0.5 m ahead of the lens is in view while 11 deg above the horizon still is.
    """

    native_width_px: int = 640
    native_height_px: int = 480
    downscale: int = 2
    vertical_fov_deg: float = 42.5
    min_depth_m: float = 0.3
    max_depth_m: float = 10.0
    mount_position_m: tuple[float, float, float] = (0.28, 0.0, 0.05)
    mount_pitch_down_deg: float = 10.0

    def __post_init__(self) -> None:
        for name in ("native_width_px", "native_height_px", "downscale"):
            value = getattr(self, name)
            if not isinstance(value, int) or value <= 0:
                raise InvalidInputError(f"CameraConfig.{name} must be a positive int, got {value!r}")
        if self.native_width_px % self.downscale or self.native_height_px % self.downscale:
            raise InvalidInputError(
                f"CameraConfig.downscale={self.downscale} must divide the native size "
                f"{self.native_width_px}x{self.native_height_px}"
            )
        numbers = {
            "vertical_fov_deg": self.vertical_fov_deg,
            "min_depth_m": self.min_depth_m,
            "max_depth_m": self.max_depth_m,
            "mount_pitch_down_deg": self.mount_pitch_down_deg,
        }
        for name, value in numbers.items():
            if not math.isfinite(value):
                raise InvalidInputError(f"CameraConfig.{name} must be finite, got {value!r}")
        if not all(math.isfinite(v) for v in self.mount_position_m) or len(self.mount_position_m) != 3:
            raise InvalidInputError(
                f"CameraConfig.mount_position_m must be 3 finite numbers, got {self.mount_position_m!r}"
            )
        if not 1.0 < self.vertical_fov_deg < 170.0:
            raise InvalidInputError(
                f"CameraConfig.vertical_fov_deg must lie in (1, 170), got {self.vertical_fov_deg}"
            )
        if not NEAR_CLIP_M < self.min_depth_m < self.max_depth_m < FAR_CLIP_M:
            raise InvalidInputError(
                f"CameraConfig depth range must satisfy {NEAR_CLIP_M} < min_depth_m < max_depth_m < {FAR_CLIP_M}, "
                f"got {self.min_depth_m}..{self.max_depth_m}"
            )
        if not -90.0 < self.mount_pitch_down_deg < 90.0:
            raise InvalidInputError(
                f"CameraConfig.mount_pitch_down_deg must lie in (-90, 90), got {self.mount_pitch_down_deg}"
            )

    @property
    def width_px(self) -> int:
        """Rendered image width."""
        return self.native_width_px // self.downscale

    @property
    def height_px(self) -> int:
        """Rendered image height."""
        return self.native_height_px // self.downscale

    def intrinsics(self) -> CameraIntrinsics:
        """Pinhole intrinsics of the rendered image (principal point at the centre, square pixels)."""
        return CameraIntrinsics.from_fov(
            width_px=self.width_px, height_px=self.height_px, vertical_fov_deg=self.vertical_fov_deg
        )

    def optical_to_base(self) -> FloatArray:
        """T_trunk<-optical (4x4) of the mount (``robots.mount``: the ROS 2 profile's mount gives the same
        bits for the same numbers). The simulated camera pitches only."""
        return optical_to_base(self.mount_position_m, 0.0, math.radians(self.mount_pitch_down_deg), 0.0)

    def mujoco_xyaxes(self) -> tuple[float, ...]:
        """The MJCF ``xyaxes`` of the camera in the trunk frame: image right (optical x), then image up
        (optical -y), from :meth:`optical_to_base`."""
        rotation = self.optical_to_base()[:3, :3]
        return tuple(float(v) + 0.0 for v in rotation[:, 0]) + tuple(-float(v) + 0.0 for v in rotation[:, 1])


@dataclass
class RgbdFrame:
    """One rendered frame.

    Attributes:
        rgb: ``(H, W, 3)`` uint8.
        depth_m: ``(H, W)`` float32 depth along the optical axis, 0 outside the valid range.
        segmentation: ``(H, W)`` int32 scene object ids, ``BACKGROUND_OBJECT_ID`` elsewhere; None if
            not rendered.
    """

    rgb: npt.NDArray[np.uint8]
    depth_m: npt.NDArray[np.float32]
    segmentation: npt.NDArray[np.int32] | None


def _gl_context_class() -> type:
    """The GL context class: MUJOCO_GL's choice, or EGL on a headless Linux machine when it is unset."""
    if not os.environ.get("MUJOCO_GL") and platform.system() == "Linux" and not os.environ.get("DISPLAY"):
        from mujoco.egl import GLContext as EglContext

        return EglContext
    context_class = getattr(mujoco, "GLContext", None)
    if context_class is None:
        raise RuntimeError(
            "MuJoCo has no OpenGL backend: set MUJOCO_GL=egl (or osmesa) before importing mujoco"
        )
    return context_class


def depth_from_reversed_z(
    window_depth: npt.NDArray[np.float32], *, near_m: float, far_m: float
) -> FloatArray:
    """Convert a reversed-Z window depth (1 at near, 0 at far) to distance along the optical axis.

    Args:
        window_depth: values in [0, 1] read from MuJoCo's depth buffer.
        near_m: near clip plane distance.
        far_m: far clip plane distance.
    """
    z_w = window_depth.astype(np.float64)
    return near_m * far_m / (near_m + z_w * (far_m - near_m))


class RgbdCamera:
    """Offscreen RGB, depth and segmentation renders of one MJCF camera.

    The camera owns its GL context; create it after the model and close it before dropping the model.
    It sets ``model.vis.map.znear/zfar`` so that the clip planes are :data:`NEAR_CLIP_M` and
    :data:`FAR_CLIP_M` whatever the scene's extent.

    Args:
        model: the compiled model; its offscreen buffer must be at least the render size.
        config: the camera configuration (image size, FoV, depth range).
        camera_name: the MJCF camera to render.
        geom_object_ids: ``(model.ngeom,)`` scene object id of each geom, ``BACKGROUND_OBJECT_ID`` for the
            floor, the robot and anything that is not a scene object.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        *,
        config: CameraConfig,
        camera_name: str,
        geom_object_ids: npt.NDArray[np.int32],
    ) -> None:
        self._model = model
        self._config = config
        self._camera_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera_name)
        if self._camera_id < 0:
            raise ValueError(f"model has no camera named '{camera_name}'")
        if geom_object_ids.shape != (model.ngeom,):
            raise ValueError(f"geom_object_ids must have shape ({model.ngeom},), got {geom_object_ids.shape}")
        width, height = config.width_px, config.height_px
        if width > model.vis.global_.offwidth or height > model.vis.global_.offheight:
            raise ValueError(
                f"render size {width}x{height} exceeds the model's offscreen buffer "
                f"{model.vis.global_.offwidth}x{model.vis.global_.offheight} (<visual><global offwidth/offheight>)"
            )
        extent = float(model.stat.extent)
        model.vis.map.znear = NEAR_CLIP_M / extent
        model.vis.map.zfar = FAR_CLIP_M / extent
        self._near_m = float(np.float32(model.vis.map.znear * extent))
        self._far_m = float(np.float32(model.vis.map.zfar * extent))
        self._geom_object_ids = geom_object_ids.astype(np.int32)

        self._gl = _gl_context_class()(width, height)
        self._gl.make_current()
        self._mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._mjr)
        self._mjr.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._scene = mujoco.MjvScene(model, maxgeom=max(1000, 2 * model.ngeom))
        for flag in _SLOW_RENDER_FLAGS:
            self._scene.flags[flag] = False
        has_skybox = bool(np.any(model.tex_type == mujoco.mjtTexture.mjTEXTURE_SKYBOX))
        self._scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = has_skybox
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._camera.fixedcamid = self._camera_id
        self._rgb = np.empty((height, width, 3), dtype=np.uint8)
        self._depth = np.empty((height, width), dtype=np.float32)
        self._closed = False

    @property
    def config(self) -> CameraConfig:
        return self._config

    @property
    def intrinsics(self) -> CameraIntrinsics:
        return self._config.intrinsics()

    def camera_to_world(self, data: mujoco.MjData) -> FloatArray:
        """T_w<-c of the optical frame (x right, y down, z forward) from the last forward kinematics."""
        transform = np.eye(4)
        rotation_mujoco = data.cam_xmat[self._camera_id].reshape(3, 3)
        transform[:3, :3] = rotation_mujoco @ MUJOCO_TO_OPTICAL
        transform[:3, 3] = data.cam_xpos[self._camera_id]
        return transform

    def _update_scene(self, data: mujoco.MjData) -> None:
        if self._closed:
            raise RuntimeError("RgbdCamera is closed")
        self._gl.make_current()
        mujoco.mjv_updateScene(
            self._model, data, self._option, None, self._camera, mujoco.mjtCatBit.mjCAT_ALL, self._scene
        )

    def _pass(self, *, flat: bool, id_colours: bool, read_rgb: bool, read_depth: bool) -> None:
        """One GL pass into ``_rgb``/``_depth``; flat (segmentation-mode) flags are reset afterwards."""
        self._scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = flat
        self._scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = id_colours
        try:
            mujoco.mjr_render(self._rect, self._scene, self._mjr)
            mujoco.mjr_readPixels(
                self._rgb if read_rgb else None, self._depth if read_depth else None, self._rect, self._mjr
            )
        finally:
            self._scene.flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = False
            self._scene.flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = False

    def _rgbd_pass(self, *, read_rgb: bool, read_depth: bool) -> None:
        self._pass(flat=False, id_colours=False, read_rgb=read_rgb, read_depth=read_depth)

    def _depth_pass(self) -> None:
        # Flat colours (segmentation mode) skip lighting and textures, which the software rasteriser pays
        # for per vertex and pixel; the depth buffer is the same to the bit (tests/test_mujoco_backend.py).
        self._pass(flat=True, id_colours=False, read_rgb=False, read_depth=True)

    def _depth_metres(self) -> npt.NDArray[np.float32]:
        depth = depth_from_reversed_z(np.flipud(self._depth), near_m=self._near_m, far_m=self._far_m)
        valid = (depth >= self._config.min_depth_m) & (depth <= self._config.max_depth_m)
        return round_depth_to_millimetres(np.where(valid, depth, 0.0).astype(np.float32))

    def _segmentation_pass(self) -> npt.NDArray[np.int32]:
        self._pass(flat=True, id_colours=True, read_rgb=True, read_depth=False)
        # IDCOLOR paints scene geom i with colour i + 1 (little-endian RGB); 0 is the cleared background.
        colour = self._rgb.astype(np.int32)
        segment = np.flipud(colour[:, :, 0] | (colour[:, :, 1] << 8) | (colour[:, :, 2] << 16))
        num_scene_geoms = self._scene.ngeom
        segment_to_object = np.full(num_scene_geoms + 1, BACKGROUND_OBJECT_ID, dtype=np.int32)
        geom_type = int(mujoco.mjtObj.mjOBJ_GEOM)
        for index in range(num_scene_geoms):
            scene_geom = self._scene.geoms[index]
            if scene_geom.objtype == geom_type and scene_geom.segid >= 0:
                segment_to_object[scene_geom.segid + 1] = self._geom_object_ids[scene_geom.objid]
        segment = np.clip(segment, 0, num_scene_geoms)
        return segment_to_object[segment]

    def render(self, data: mujoco.MjData, *, segmentation: bool = True) -> RgbdFrame:
        """Render colour, depth and (optionally) segmentation for the current ``data``.

        ``data`` must have had forward kinematics (``mj_forward`` or ``mj_kinematics`` + ``mj_camlight``).
        """
        self._update_scene(data)
        self._rgbd_pass(read_rgb=True, read_depth=True)
        rgb = np.flipud(self._rgb).copy()
        depth = self._depth_metres()
        seg = self._segmentation_pass() if segmentation else None
        return RgbdFrame(rgb=rgb, depth_m=depth, segmentation=seg)

    def render_rgb(self, data: mujoco.MjData) -> npt.NDArray[np.uint8]:
        """Colour only (for benchmarks and previews)."""
        self._update_scene(data)
        self._rgbd_pass(read_rgb=True, read_depth=False)
        return np.flipud(self._rgb).copy()

    def render_depth(self, data: mujoco.MjData) -> npt.NDArray[np.float32]:
        """Depth only, in metres along the optical axis."""
        self._update_scene(data)
        self._depth_pass()
        return self._depth_metres()

    def ray_depth(
        self, data: mujoco.MjData, *, pixel_grids: Sequence[PixelGrid], exclude_body_id: int
    ) -> npt.NDArray[np.float32]:
        """Depth at the grids' pixels only, by casting one ray per pixel (``mj_multiRay``); NaN elsewhere.

        No rasteriser is involved: at the planner's and the map's 6,420 pixels of a 320x240 frame this
        costs about a quarter of :meth:`render_depth` on llvmpipe (docs/simulation.md). A pixel ``(r, c)``
        is the ray through ``((c - cx) / fx, (r - cy) / fy, 1)``, the model every depth consumer
        back-projects with, so a point measured here back-projects onto the surface it hit. The rays see
        the geom groups the renderer draws; ``exclude_body_id`` is the body that houses the camera (the
        trunk), which the rasteriser never shows from inside. Validity follows :meth:`render_depth`:
        outside ``[min_depth_m, max_depth_m]`` or no hit reads 0.

        ``data`` must have had forward kinematics (``mj_kinematics``).
        """
        if self._closed:
            raise RuntimeError("RgbdCamera is closed")
        rays = pixel_rays(
            self.intrinsics,
            height_px=self._config.height_px,
            width_px=self._config.width_px,
            pixel_grids=tuple(pixel_grids),
            max_depth_m=self._config.max_depth_m,
        )
        optical_to_world = data.cam_xmat[self._camera_id].reshape(3, 3) @ MUJOCO_TO_OPTICAL
        return cast_depth(
            self._model,
            data,
            rays,
            origin_m=data.cam_xpos[self._camera_id],
            optical_to_world=optical_to_world,
            geomgroup=self._option.geomgroup,
            exclude_body_id=exclude_body_id,
            depth_range_m=(self._config.min_depth_m, self._config.max_depth_m),
            shape=(self._config.height_px, self._config.width_px),
        )

    def render_segmentation(self, data: mujoco.MjData) -> npt.NDArray[np.int32]:
        """Segmentation only: scene object id per pixel."""
        self._update_scene(data)
        return self._segmentation_pass()

    def close(self) -> None:
        """Free the GL resources (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self._gl.make_current()
        self._mjr.free()
        self._gl.free()
