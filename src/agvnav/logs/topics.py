"""The topics of an agvnav log, their ROS 2 message types and frames: the one place that names them.

Frames follow REP-105: ``map`` (the reflector map), ``odom`` (the wheel odometry's
frame, equal to the vehicle's start pose), ``base_link`` (the vehicle) and
``goniometer`` (the laser head, a static child of ``base_link``). Every pose is
planar (z = 0, yaw as a quaternion about z). Stamps are nanoseconds since the
start of the run; the MCAP log time of a reflection is its arrival, the header
stamp the measurement instant delivered to the estimator.
"""

from __future__ import annotations

__all__ = [
    "BEARING",
    "COMMAND",
    "COMMAND_FIELDS",
    "ESTIMATE",
    "FRAME_BASE",
    "FRAME_HEAD",
    "FRAME_MAP",
    "FRAME_ODOM",
    "GUIDANCE",
    "GUIDANCE_FIELDS",
    "JOINT_STATES",
    "ODOM",
    "PATH",
    "REFLECTIONS",
    "REFLECTOR_MAP",
    "SETTINGS",
    "STATUS",
    "STATUS_FIELDS",
    "TF",
    "TF_STATIC",
    "TOPICS",
    "TRUTH",
]

FRAME_MAP = "map"
FRAME_ODOM = "odom"
FRAME_BASE = "base_link"
FRAME_HEAD = "goniometer"

TF = "/tf"
TF_STATIC = "/tf_static"
ODOM = "/odom"
ESTIMATE = "/agvnav/estimate"
TRUTH = "/agvnav/truth"
PATH = "/agvnav/path"
REFLECTOR_MAP = "/agvnav/reflector_map"
REFLECTIONS = "/agvnav/reflections"
BEARING = "/agvnav/bearing"
GUIDANCE = "/agvnav/guidance"
COMMAND = "/agvnav/command"
STATUS = "/agvnav/status"
JOINT_STATES = "/joint_states"
SETTINGS = "/agvnav/settings"

#: topic -> (ROS 2 message type, meaning). docs/logs.md is written from the same table.
TOPICS: dict[str, tuple[str, str]] = {
    TF: ("tf2_msgs/msg/TFMessage", "map -> odom (estimate times odometry inverse) and odom -> base_link, every step"),
    TF_STATIC: ("tf2_msgs/msg/TFMessage", "base_link -> goniometer: the head's mount, once"),
    ODOM: ("nav_msgs/msg/Odometry", (
        "wheel odometry in odom: pose integrated from the encoders' increments; twist = the last step's "
        "increment divided by the step (linear.x forward m/s, linear.y lateral m/s, angular.z rad/s)"
    )),
    ESTIMATE: ("geometry_msgs/msg/PoseWithCovarianceStamped", "estimated base_link pose in map with its covariance"),
    TRUTH: ("geometry_msgs/msg/PoseStamped", "true base_link pose in map (simulation only)"),
    PATH: ("nav_msgs/msg/Path", "planned path of the tracked point in map, once"),
    REFLECTOR_MAP: ("visualization_msgs/msg/MarkerArray", "the reflectors of the map as cylinders, once"),
    REFLECTIONS: ("visualization_msgs/msg/MarkerArray", "each goniometer reflection as a ray from the head"),
    BEARING: ("geometry_msgs/msg/Vector3Stamped", (
        "each reflection's bearing (vector.x, rad, head frame); header stamp = measurement instant, "
        "log time = arrival"
    )),
    GUIDANCE: ("std_msgs/msg/Float64MultiArray", "guidance errors, fields named in layout.dim[0].label"),
    COMMAND: ("std_msgs/msg/Float64MultiArray", "the autopilot's commands, fields named in layout.dim[0].label"),
    STATUS: ("std_msgs/msg/Float64MultiArray", "estimator status code, quality and guard level"),
    JOINT_STATES: ("sensor_msgs/msg/JointState", "steering angles and wheel angles/speeds"),
    SETTINGS: ("std_msgs/msg/String", "JSON: the positioning settings (method, mount, goniometer, noise), once"),
}

#: Fields of :data:`GUIDANCE` (m, rad, m, rad): the follower's view, then the truth.
GUIDANCE_FIELDS = ("lateral_error_est", "heading_error_est", "lateral_error", "heading_error")
#: Fields of :data:`COMMAND` (m/s, m/s, rad/s).
COMMAND_FIELDS = ("v_cmd", "v_lateral_cmd", "rate_cmd")
#: Fields of :data:`STATUS` (codes as timeseries.csv's est_status; quality 0-1; guard 0-2).
STATUS_FIELDS = ("est_status", "est_quality", "guard_level")
