"""A simulated run's MCAP log, read back by a different reader (rosbags) than the one that wrote it (mcap-ros2).

Every topic of agvnav.logs.topics is there with its standard ROS 2 type, the counts
match the run (one per step, one per reflection, one for the static parts) and
sampled values equal the run's series and events.
"""

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from agvnav.geometry import compose
from agvnav.logs import TOPICS, read_mcap, write_run_log
from agvnav.logs import topics as tp
from agvnav.sim import simulate
from agvnav.world.scenario import load_scenario

STEP_TOPICS = (tp.TF, tp.ODOM, tp.ESTIMATE, tp.TRUTH, tp.GUIDANCE, tp.COMMAND, tp.STATUS, tp.JOINT_STATES)
ONCE_TOPICS = (tp.TF_STATIC, tp.PATH, tp.REFLECTOR_MAP, tp.SETTINGS)


def _short():
    """The seed-000 guidance test's first 10 s (the transient and the straight): a short log."""
    return load_scenario("guidance_test").model_copy(update={"duration_s": 10.0})


@pytest.fixture(scope="module")
def run_and_log(tmp_path_factory):
    result = simulate(_short())
    path = tmp_path_factory.mktemp("log") / "run.mcap"
    counts = write_run_log(result, path)
    return result, path, counts


@pytest.fixture(scope="module")
def decoded(run_and_log):
    return _read_all(run_and_log[1])


def _read_all(path: Path) -> tuple[dict[str, str], dict[str, list]]:
    """topic -> message type, topic -> [(log time s, message)] decoded by rosbags."""
    types: dict[str, str] = {}
    msgs: dict[str, list] = {}
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        for c in reader.connections:
            types[c.topic] = c.msgtype
        for conn, t_ns, raw in reader.messages():
            msgs.setdefault(conn.topic, []).append((t_ns / 1e9, reader.deserialize(raw, conn.msgtype)))
    return types, msgs


def _yaw(q) -> float:
    return 2 * math.atan2(q.z, q.w)


def test_every_topic_with_its_standard_type_and_count(run_and_log, decoded):
    result, _, counts = run_and_log
    types, msgs = decoded
    assert types == {topic: msgtype for topic, (msgtype, _) in TOPICS.items()}
    n, m = result.series["t"].size, result.events["reflections"]["t"].size
    got = {topic: len(v) for topic, v in msgs.items()}
    assert got == counts
    assert all(got[t] == n for t in STEP_TOPICS)
    assert all(got[t] == 1 for t in ONCE_TOPICS)
    assert got[tp.BEARING] == got[tp.REFLECTIONS] == m > 100


def test_sampled_values_equal_the_run(run_and_log, decoded):
    result = run_and_log[0]
    s, refl = result.series, result.events["reflections"]
    _, msgs = decoded
    for k in (0, 7, s["t"].size // 2, s["t"].size - 1):
        est = msgs[tp.ESTIMATE][k][1]
        assert est.header.stamp.sec + est.header.stamp.nanosec * 1e-9 == pytest.approx(s["t"][k], abs=1e-9)
        assert est.header.frame_id == "map"
        p = est.pose.pose
        assert (p.position.x, p.position.y) == (s["est_x"][k], s["est_y"][k])
        assert _yaw(p.orientation) == pytest.approx(s["est_psi"][k], abs=1e-12)
        cov = est.pose.covariance.reshape(6, 6)
        assert (cov[0, 0], cov[0, 1], cov[1, 1], cov[5, 5]) == (
            s["est_cov_xx"][k], s["est_cov_xy"][k], s["est_cov_yy"][k], s["est_cov_psipsi"][k])
        truth = msgs[tp.TRUTH][k][1].pose
        assert (truth.position.x, truth.position.y) == (s["x"][k], s["y"][k])
        guidance = msgs[tp.GUIDANCE][k][1]
        assert guidance.layout.dim[0].label.split(",") == list(tp.GUIDANCE_FIELDS)
        assert guidance.data[2] == s["lateral_error"][k]
        status = msgs[tp.STATUS][k][1]
        assert status.data[0] == s["est_status"][k]
        joints = msgs[tp.JOINT_STATES][k][1]
        assert joints.name[0] == "steer_gamma" and joints.position[0] == s["gamma"][k]
    for k in (1, 100, s["t"].size - 1):  # odometry twist times the step is the encoders' increment
        dt = s["t"][k] - s["t"][k - 1]
        odom = msgs[tp.ODOM][k][1]
        assert odom.twist.twist.linear.x * dt == pytest.approx(s["odo_dd"][k], rel=1e-12, abs=1e-15)
        assert odom.twist.twist.angular.z * dt == pytest.approx(s["odo_dtheta"][k], rel=1e-12, abs=1e-15)
        assert odom.header.frame_id == "odom" and odom.child_frame_id == "base_link"
    for i in (0, 50, refl["t"].size - 1):
        log_t, b = msgs[tp.BEARING][i]
        assert b.vector.x == refl["bearing"][i] and log_t == pytest.approx(refl["t"][i], abs=1e-9)
        ray = msgs[tp.REFLECTIONS][i][1].markers[0]
        assert ray.header.frame_id == "goniometer" and len(ray.points) == 2
        assert math.atan2(ray.points[1].y, ray.points[1].x) == pytest.approx(refl["bearing"][i], abs=1e-12)


def test_tf_chain_map_odom_base_is_the_estimate_and_static_mount(run_and_log, decoded):
    result = run_and_log[0]
    s = result.series
    _, msgs = decoded
    for k in (0, 123, s["t"].size - 1):
        tfs = {(tf.header.frame_id, tf.child_frame_id): tf.transform for tf in msgs[tp.TF][k][1].transforms}
        assert set(tfs) == {("map", "odom"), ("odom", "base_link")}
        a, b = tfs[("map", "odom")], tfs[("odom", "base_link")]
        chain = compose([a.translation.x, a.translation.y, _yaw(a.rotation)],
                        [b.translation.x, b.translation.y, _yaw(b.rotation)])
        np.testing.assert_allclose(chain[:2], [s["est_x"][k], s["est_y"][k]], atol=1e-9)
        assert math.remainder(chain[2] - s["est_psi"][k], 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    static = msgs[tp.TF_STATIC][0][1].transforms[0]
    mount = result.scenario.goniometer.mount
    assert (static.header.frame_id, static.child_frame_id) == ("base_link", "goniometer")
    assert (static.transform.translation.x, static.transform.translation.y) == (mount[0], mount[1])


def test_static_parts_map_path_settings(run_and_log, decoded):
    result = run_and_log[0]
    _, msgs = decoded
    markers = msgs[tp.REFLECTOR_MAP][0][1].markers
    xy = [[mk.pose.position.x, mk.pose.position.y] for mk in markers]
    np.testing.assert_array_equal(xy, result.world.reflector_xy)
    np.testing.assert_allclose([mk.scale.x / 2 for mk in markers], result.world.reflector_radius)
    poses = msgs[tp.PATH][0][1].poses
    assert (poses[0].pose.position.x, poses[0].pose.position.y) == pytest.approx(tuple(result.path.point_at(0.0)))
    end = result.path.point_at(result.path.length)
    assert (poses[-1].pose.position.x, poses[-1].pose.position.y) == pytest.approx(tuple(end))
    settings = json.loads(msgs[tp.SETTINGS][0][1].data)
    assert settings["method"] == "ekf" and settings["map"] == "lab"
    assert settings["initial_pose"] == [result.series[c][0] for c in ("est_x", "est_y", "est_psi")]


def test_the_library_reader_agrees_with_rosbags(run_and_log):
    result, path, _ = run_and_log
    log = read_mcap(path)
    s = result.series
    np.testing.assert_allclose(log.t, s["t"], atol=1e-9)
    np.testing.assert_allclose(log.increments[:, 0], s["odo_dd"][1:], rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(log.bearing, result.events["reflections"]["bearing"])
    np.testing.assert_array_equal(log.estimate[:, :2], np.column_stack([s["est_x"], s["est_y"]]))
    assert log.truth is not None and log.path_xy is not None


def test_a_damaged_file_is_refused_with_its_name(tmp_path):
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap file at all")
    with pytest.raises(ValueError, match=r"bad\.mcap"):
        read_mcap(bad)


def test_a_decimated_run_is_refused(run_and_log, tmp_path):
    """Every k-th step recorded: the increments of the steps between are missing, so no log."""
    result = run_and_log[0]
    thinned = {k: v[::2] for k, v in result.series.items()}
    with pytest.raises(ValueError, match="every step recorded"):
        write_run_log(dataclasses.replace(result, series=thinned), tmp_path / "thin.mcap")
