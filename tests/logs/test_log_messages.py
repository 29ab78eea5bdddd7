"""ROS 2 message helpers of agvnav.logs: planar poses, covariances, stamps, odometry integration."""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from agvnav.logs import TOPICS
from agvnav.logs.messages import covariance6, quaternion_yaw, stamp, stamp_ns, yaw_of
from agvnav.logs.runlog import integrate_odometry
from agvnav.logs.writer import message_definition


class _Q:
    def __init__(self, q: dict) -> None:
        self.x, self.y, self.z, self.w = q["x"], q["y"], q["z"], q["w"]


@given(st.floats(-math.pi + 1e-9, math.pi))
def test_yaw_survives_the_quaternion(psi):
    q = quaternion_yaw(psi)
    assert math.isclose(q["x"] ** 2 + q["y"] ** 2 + q["z"] ** 2 + q["w"] ** 2, 1.0, rel_tol=1e-12)
    assert math.isclose(yaw_of(_Q(q)), psi, abs_tol=1e-12)


def test_quarter_turn_quaternion_is_the_textbook_one():
    q = quaternion_yaw(math.pi / 2)
    assert q["z"] == pytest.approx(math.sqrt(0.5)) and q["w"] == pytest.approx(math.sqrt(0.5))


def test_planar_covariance_lands_on_x_y_yaw_of_the_ros_6x6():
    c3 = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 5.0], [3.0, 5.0, 6.0]])
    c6 = np.array(covariance6(c3)).reshape(6, 6)
    assert c6[0, 0] == 1 and c6[0, 1] == 2 and c6[0, 5] == 3 and c6[1, 5] == 5 and c6[5, 5] == 6 and c6[5, 0] == 3
    assert c6[2, 2] == 0 and c6[3, 3] == 0 and np.count_nonzero(c6) == 9
    with pytest.raises(ValueError, match="shape"):
        covariance6(np.eye(2))


def test_stamps_split_seconds_and_nanoseconds_and_refuse_bad_times():
    assert stamp(12.345678901) == {"sec": 12, "nanosec": 345678901}
    assert stamp_ns(0.05) == 50_000_000
    for bad in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="log time"):
            stamp_ns(bad)


def test_standard_message_definitions_come_with_their_dependencies():
    name, text = message_definition("nav_msgs/msg/Odometry")
    assert name == "nav_msgs/msg/Odometry"
    assert "geometry_msgs/PoseWithCovariance pose" in text and "MSG: builtin_interfaces/Time" in text
    with pytest.raises(ValueError, match="unknown ROS 2 message type"):
        message_definition("nav_msgs/msg/NoSuchThing")


def test_odometry_integration_straight_turn_and_circle():
    straight = integrate_odometry(np.array([[0.5, 0.0, 0.0]] * 4))
    np.testing.assert_allclose(straight[-1], [2.0, 0.0, 0.0], atol=1e-15)
    sideways = integrate_odometry(np.array([[0.0, 0.0, 0.25]] * 4))  # holonomic crab walk
    np.testing.assert_allclose(sideways[-1], [0.0, 1.0, 0.0], atol=1e-15)
    # a full circle of radius 2 m in 2000 steps: back at the start (midpoint rule error O(step^2))
    n, r = 2000, 2.0
    circle = integrate_odometry(np.tile([2 * math.pi * r / n, 2 * math.pi / n, 0.0], (n, 1)))
    np.testing.assert_allclose(circle[-1, :2], [0.0, 0.0], atol=1e-5)
    half = circle[n // 2]
    np.testing.assert_allclose(half[:2], [0.0, 2 * r], atol=1e-5)


def test_docs_list_every_topic_with_its_type():
    text = (Path(__file__).parents[2] / "docs" / "logs.md").read_text(encoding="utf-8")
    for topic, (msgtype, meaning) in TOPICS.items():
        assert f"| `{topic}` | `{msgtype}` | {meaning} |" in text, topic
