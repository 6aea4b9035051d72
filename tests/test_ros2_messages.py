"""Message conversions (robots/ros2_messages.py) against rclpy's own serialisation and rosbags' CDR.

Every case encodes with our functions into rclpy's generated message, serialises it with
``rclpy.serialization`` (the bytes Fast DDS sends), then decodes both what rclpy deserialises and what
rosbags (an independent CDR implementation of the Jazzy types) reads from the same bytes.
Needs the ROS 2 environment (``make ros2-env``); skipped elsewhere.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

pytest.importorskip("rclpy", reason="the ROS 2 environment (make ros2-env) provides rclpy")

from geometry_msgs.msg import Twist as TwistMsg
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_typestore
from sensor_msgs.msg import CameraInfo, Image, Imu, JointState

from robots.go1 import load_go1_spec
from robots.mount import rotation_from_rpy
from robots.ros2_messages import (
    MessageError,
    camera_info_to_intrinsics,
    depth_grid_image_to_depth_m,
    depth_to_millimetres,
    fill_camera_info,
    fill_depth_grid_image,
    fill_depth_image,
    fill_imu,
    fill_joint_state,
    fill_odometry,
    fill_rgb_image,
    fill_segmentation_image,
    fill_twist,
    image_to_depth_m,
    image_to_rgb,
    image_to_segmentation,
    imu_to_reading,
    joint_state_from_msg,
    matrix_to_quaternion,
    odometry_to_transform,
    odometry_to_twist,
    pose2d_of,
    round_depth_to_millimetres,
    twist_from_msg,
)
from semexp_bt.core.types import CameraIntrinsics, ImuReading, PixelGrid, Twist
from semexp_bt.core.types import JointState as JointStateValue

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


def _both_ways(msg: object, type_name: str) -> tuple[object, object, object]:
    """``msg`` after three trips through CDR: rclpy -> rclpy, rclpy -> rosbags, and rosbags' own bytes of
    what it read -> rclpy (padding bytes may differ between the two writers; the values may not)."""
    data = bytes(serialize_message(msg))
    through_rclpy = deserialize_message(data, type(msg))
    through_rosbags = _rosbags_read(data, type_name)
    rosbags_bytes = bytes(TYPESTORE.serialize_cdr(through_rosbags, type_name))
    assert 0 <= len(data) - len(rosbags_bytes) < 8
    return through_rclpy, through_rosbags, deserialize_message(rosbags_bytes, type(msg))


def _rosbags_read(data: bytes, type_name: str) -> object:
    """rosbags' reading of rclpy's bytes. Fast CDR may end a buffer with up to 7 alignment bytes more than
    rosbags accepts (it allows 3): those are trimmed, nothing else."""
    for trailing in range(8):
        try:
            return TYPESTORE.deserialize_cdr(data[: len(data) - trailing], type_name)
        except SerdeError:
            continue
    raise AssertionError(f"rosbags cannot read rclpy's {type_name}")


def test_rgb8_round_trips_through_cdr() -> None:
    rgb = np.random.default_rng(0).integers(0, 256, size=(24, 32, 3), dtype=np.uint8)
    msg = Image()
    fill_rgb_image(msg, rgb, stamp_s=12.5, frame_id="camera_color_optical_frame")
    assert (msg.encoding, msg.step, msg.header.stamp.sec, msg.header.stamp.nanosec) == (
        "rgb8",
        96,
        12,
        500_000_000,
    )
    for decoded in _both_ways(msg, "sensor_msgs/msg/Image"):
        np.testing.assert_array_equal(image_to_rgb(decoded), rgb)


def test_bgr8_is_swapped_and_row_padding_is_dropped() -> None:
    rgb = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    msg = Image(height=2, width=3, encoding="bgr8", step=12)  # 3 padding bytes per row
    rows = np.zeros((2, 12), dtype=np.uint8)
    rows[:, :9] = rgb[:, :, ::-1].reshape(2, 9)
    msg.data = rows.tobytes()
    np.testing.assert_array_equal(image_to_rgb(msg), rgb)


def test_16uc1_millimetres_become_metres_with_zero_kept_as_invalid() -> None:
    depth_m = np.array(
        [[0.0, 0.3004, 1.2346, np.nan, np.inf], [-1.0, 65.535, 70.0, 9.9995, -np.inf]], dtype=np.float32
    )
    msg = Image()
    fill_depth_image(msg, depth_m, stamp_s=0.02, frame_id="camera_color_optical_frame")
    assert msg.encoding == "16UC1" and msg.step == 10
    expected = np.array([[0.0, 0.300, 1.235, 0.0, 0.0], [0.0, 65.535, 0.0, 10.0, 0.0]], dtype=np.float32)
    for decoded in _both_ways(msg, "sensor_msgs/msg/Image"):
        depth = image_to_depth_m(decoded)
        assert depth.dtype == np.float32
        np.testing.assert_allclose(depth, expected, atol=1e-6)
    # Encoding is nearest-millimetre: no valid depth moves by more than half a millimetre.
    valid = np.isfinite(depth_m) & (depth_m > 0) & (depth_m <= 65.535)
    assert np.all(np.abs(image_to_depth_m(msg)[valid] - depth_m[valid]) <= 5e-4 + 1e-6)


@given(
    st.lists(
        st.floats(min_value=-2.0, max_value=70.0, width=32)
        | st.sampled_from([math.nan, math.inf, -math.inf]),
        min_size=1,
        max_size=64,
    )
)
def test_depth_is_stored_to_the_nearest_millimetre_and_the_simulated_camera_rounds_as_the_wire(
    values: list[float],
) -> None:
    depth_m = np.array(values, dtype=np.float32).reshape(1, -1)
    millimetres = depth_to_millimetres(depth_m)
    # The definition: the nearest millimetre of the float64 value; NaN, infinities, <= 0 and beyond
    # 65.535 m store 0 (no depth).
    for value, stored in zip(depth_m.ravel().tolist(), millimetres.ravel().tolist(), strict=True):
        nearest = round(value * 1e3) if math.isfinite(value) else 0
        assert stored == (nearest if 0 < nearest <= 65535 else 0)
    rounded = round_depth_to_millimetres(depth_m)
    assert rounded.dtype == np.float32
    assert np.array_equal(np.isnan(rounded), np.isnan(depth_m))
    measured = ~np.isnan(depth_m)
    assert np.array_equal(rounded[measured], (millimetres.astype(np.float32) * np.float32(1e-3))[measured])


def test_a_depth_grid_image_decodes_to_the_whole_frames_depth_on_its_pixels_and_none_elsewhere() -> None:
    """A lockstep render asked at pixel grids travels as the grids' rows and columns only
    (``/sim/camera/depth_grid``); put back, it is what the whole frame decodes to on every pixel a grid
    reads, and no depth (0) on the others. Two grids: the union of their rows and columns."""
    rng = np.random.default_rng(7)
    depth_m = rng.uniform(0.2, 12.0, size=(240, 320)).astype(np.float32)
    depth_m[rng.random(depth_m.shape) < 0.1] = np.nan  # not measured, or no return
    grids = (PixelGrid.centred(40), PixelGrid(stride=16, offset=3))
    whole, sparse = Image(), Image()
    fill_depth_image(whole, depth_m, stamp_s=1.5, frame_id="camera_color_optical_frame")
    fill_depth_grid_image(sparse, depth_m, grids, stamp_s=1.5, frame_id="camera_color_optical_frame")
    rows = np.union1d(grids[0].indices(240), grids[1].indices(240))
    cols = np.union1d(grids[0].indices(320), grids[1].indices(320))
    assert (sparse.height, sparse.width) == (rows.size, cols.size) == (21, 28)
    assert len(sparse.data) * 40 < len(whole.data)
    on_grid = np.zeros(depth_m.shape, dtype=bool)
    for grid in grids:
        on_grid |= grid.mask(height_px=240, width_px=320)
    expected = image_to_depth_m(whole)
    for decoded in _both_ways(sparse, "sensor_msgs/msg/Image"):
        put_back = depth_grid_image_to_depth_m(decoded, grids, height_px=240, width_px=320)
        assert put_back.dtype == np.float32 and put_back.shape == (240, 320)
        np.testing.assert_array_equal(put_back[on_grid], expected[on_grid])
        assert not put_back[~np.isin(np.arange(240), rows)[:, None] | ~np.isin(np.arange(320), cols)].any()
    with pytest.raises(MessageError, match="grids asked for 6x8"):
        depth_grid_image_to_depth_m(sparse, grids[:1], height_px=240, width_px=320)


def test_big_endian_16uc1_and_32fc1_depth_decode() -> None:
    millimetres = np.array([[1000, 2500]], dtype=">u2")
    big = Image(height=1, width=2, encoding="16UC1", is_bigendian=1, step=4)
    big.data = millimetres.tobytes()
    np.testing.assert_allclose(image_to_depth_m(big), [[1.0, 2.5]])
    metres = np.array([[1.5, np.inf, -2.0, 0.75]], dtype="<f4")
    floats = Image(height=1, width=4, encoding="32FC1", step=16)
    floats.data = metres.tobytes()
    np.testing.assert_allclose(image_to_depth_m(floats), [[1.5, 0.0, 0.0, 0.75]])


def test_segmentation_round_trips_with_the_background() -> None:
    ids = np.array([[-1, 0, 7], [65534, 3, -1]], dtype=np.int32)
    msg = Image()
    fill_segmentation_image(msg, ids, stamp_s=1.0, frame_id="camera_color_optical_frame")
    for decoded in _both_ways(msg, "sensor_msgs/msg/Image"):
        np.testing.assert_array_equal(image_to_segmentation(decoded), ids)
    with pytest.raises(MessageError, match=r"segmentation ids must lie in \[-1, 65534\]"):
        fill_segmentation_image(Image(), np.array([[70000]]), stamp_s=0.0, frame_id="")


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        (
            {"encoding": "mono8", "height": 1, "width": 1, "step": 1, "data": b"\x00"},
            "encoding 'mono8', expected rgb8",
        ),
        (
            {"encoding": "rgb8", "height": 2, "width": 2, "step": 6, "data": b"\x00" * 6},
            "6 data bytes, expected",
        ),
        (
            {"encoding": "rgb8", "height": 1, "width": 2, "step": 3, "data": b"\x00" * 3},
            "step 3 is shorter than a row",
        ),
        ({"encoding": "rgb8", "height": 0, "width": 2, "step": 6, "data": b""}, "empty image"),
    ],
)
def test_malformed_colour_images_are_refused_with_the_reason(fields: dict, match: str) -> None:
    msg = Image(**{k: v for k, v in fields.items() if k != "data"})
    msg.data = fields["data"]
    with pytest.raises(MessageError, match=match):
        image_to_rgb(msg)


def test_camera_info_round_trips_to_the_same_intrinsics() -> None:
    intrinsics = CameraIntrinsics.from_fov(width_px=320, height_px=240, vertical_fov_deg=42.5)
    msg = CameraInfo()
    fill_camera_info(msg, intrinsics, stamp_s=3.0, frame_id="camera_color_optical_frame")
    for decoded in _both_ways(msg, "sensor_msgs/msg/CameraInfo"):
        assert camera_info_to_intrinsics(decoded) == intrinsics
    with pytest.raises(MessageError, match="fx, fy > 0"):
        camera_info_to_intrinsics(CameraInfo(width=320, height=240))


@given(
    x=st.floats(-50, 50),
    y=st.floats(-50, 50),
    z=st.floats(0, 1),
    roll=st.floats(-0.5, 0.5),
    pitch=st.floats(-0.5, 0.5),
    yaw=st.floats(-math.pi, math.pi),
    vx=st.floats(-2, 2),
    wz=st.floats(-3, 3),
)
def test_odometry_round_trips_to_the_pose_and_the_body_twist(
    x: float, y: float, z: float, roll: float, pitch: float, yaw: float, vx: float, wz: float
) -> None:
    transform = np.eye(4)
    transform[:3, :3] = rotation_from_rpy(roll, pitch, yaw)
    transform[:3, 3] = [x, y, z]
    msg = Odometry()
    fill_odometry(
        msg,
        transform[:3, 3],
        matrix_to_quaternion(transform[:3, :3]),
        Twist(vx, 0.1, wz),
        stamp_s=7.25,
        odom_frame="odom",
        base_frame="base_link",
    )
    for decoded in _both_ways(msg, "nav_msgs/msg/Odometry"):
        np.testing.assert_allclose(odometry_to_transform(decoded), transform, atol=1e-12)
        pose = pose2d_of(odometry_to_transform(decoded))
        assert (pose.x_m, pose.y_m) == (x, y)
        heading = math.atan2(transform[1, 0], transform[0, 0])
        assert abs(math.remainder(pose.yaw_rad - heading, math.tau)) < 1e-9
        assert odometry_to_twist(decoded) == Twist(vx, 0.1, wz)
        assert (decoded.header.frame_id, decoded.child_frame_id) == ("odom", "base_link")


def test_non_finite_odometry_and_twists_are_refused() -> None:
    msg = Odometry()
    msg.pose.pose.position.x = math.nan
    with pytest.raises(MessageError, match="odometry position must be finite"):
        odometry_to_transform(msg)
    zero_quaternion = Odometry()
    zero_quaternion.pose.pose.orientation.w = 0.0
    with pytest.raises(MessageError, match="quaternion must be finite and non-zero"):
        odometry_to_transform(zero_quaternion)
    twist = TwistMsg()
    twist.angular.z = math.inf
    with pytest.raises(MessageError, match="twist must be finite"):
        twist_from_msg(twist)


def test_twist_imu_and_joint_states_round_trip() -> None:
    twist_msg = TwistMsg()
    fill_twist(twist_msg, Twist(0.5, -0.1, 0.3))
    for decoded in _both_ways(twist_msg, "geometry_msgs/msg/Twist"):
        assert twist_from_msg(decoded) == Twist(0.5, -0.1, 0.3)
    reading = ImuReading(
        angular_velocity_radps=np.array([0.01, -0.02, 0.3]),
        linear_acceleration_mps2=np.array([0.1, 0.0, 9.81]),
        orientation_wxyz=np.array([math.cos(0.2), 0.0, 0.0, math.sin(0.2)]),
    )
    imu = Imu()
    fill_imu(imu, reading, stamp_s=1.0, frame_id="base_link")
    for decoded in _both_ways(imu, "sensor_msgs/msg/Imu"):
        back = imu_to_reading(decoded)
        np.testing.assert_array_equal(back.orientation_wxyz, reading.orientation_wxyz)
        np.testing.assert_array_equal(back.angular_velocity_radps, reading.angular_velocity_radps)
    names = load_go1_spec().joint_names
    state = JointStateValue(position_rad=np.linspace(-1, 1, 12), velocity_radps=np.linspace(0, 2, 12))
    joints = JointState()
    fill_joint_state(joints, names, state, stamp_s=1.0)
    for decoded in _both_ways(joints, "sensor_msgs/msg/JointState"):
        back = joint_state_from_msg(decoded, names)
        np.testing.assert_array_equal(back.position_rad, state.position_rad)
    # A driver may list the joints in its own order: they are matched by name.
    shuffled = JointState(name=list(reversed(names)), position=list(reversed(state.position_rad.tolist())))
    np.testing.assert_array_equal(joint_state_from_msg(shuffled, names).position_rad, state.position_rad)
    with pytest.raises(MessageError, match="lacks joints"):
        joint_state_from_msg(JointState(name=["a"], position=[0.0]), names)
