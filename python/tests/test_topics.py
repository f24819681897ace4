"""A recording's topics as tables, against what was written and against an independent MCAP
reader and ROS 2 decoder (the mcap and mcap-ros2-support packages)."""

import numpy as np
import pytest

import terzaghi
from test_api import run

mcap_reader = pytest.importorskip("mcap.reader")
mcap_ros2 = pytest.importorskip("mcap_ros2.decoder")


def test_what_a_recorder_wrote_reads_back(tmp_path):
    path = tmp_path / "s.mcap"
    rng = np.random.default_rng(5)
    pos = rng.normal(size=(20, 2))
    force = rng.normal(size=(20, 3))
    with terzaghi.Recorder(path, {"legs": ["a"]}) as rec:
        for k in range(20):
            t = 1_700_000_000 * 10**9 + k * 10**7
            # Every fifth JointState names joint j1 only.
            if k % 5:
                rec.joint_state(t, ["j0", "j1"], pos[k], velocity=pos[k] * 2)
            else:
                rec.joint_state(t, ["j1"], pos[k, 1:], velocity=pos[k, 1:] * 2)
            rec.wrench("/a/ft", t, force[k], frame_id="a_ft")
            rec.pose("/body_pose", t, force[k], (0.0, 0.0, 0.0, 1.0))
    tables = terzaghi.read_topics(path)
    assert sorted(tables) == ["/a/ft", "/body_pose", "/joint_states"]
    j = tables["/joint_states"]
    want_j0 = np.where(np.arange(20) % 5 == 0, np.nan, pos[:, 0])
    np.testing.assert_array_equal(j["position.j0"], want_j0)
    np.testing.assert_array_equal(j["position.j1"], pos[:, 1])
    np.testing.assert_array_equal(j["velocity.j1"], pos[:, 1] * 2)
    np.testing.assert_allclose(j["stamp_s"], 1_700_000_000 + np.arange(20) * 0.01, rtol=0, atol=1e-6)
    w = tables["/a/ft"]
    for i, axis in enumerate("xyz"):
        np.testing.assert_array_equal(w[f"force_{axis}_n"], force[:, i])
    assert tables["/body_pose"]["qw"].tolist() == [1.0] * 20
    df = terzaghi.read_topics(path, ["/a/ft"], pandas=True)["/a/ft"]
    assert len(df) == 20 and list(df.columns[:2]) == ["log_time_s", "stamp_s"]
    counts = terzaghi.topic_counts(path)
    assert counts["/joint_states"] == {"type": "sensor_msgs/msg/JointState", "messages": 20,
                                       "read": True, "undecodable": 0}


def _independent(path):
    """Every message of the recording, decoded by mcap-ros2-support, by topic."""
    out = {}
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2.DecoderFactory()])
        for _schema, channel, message, msg in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append((message.log_time, msg))
    return out


def test_a_robots_recording_and_the_nodes_outputs_read_as_an_independent_reader_reads_them(tmp_path):
    robot = tmp_path / "robot.mcap"
    run("simulate-robot", "--seconds", "2", "--pose-topic", "/body_pose", "-o", robot)
    outputs = tmp_path / "outputs.mcap"
    run("replay", "--reevaluate", robot, "-o", outputs)
    for path in (robot, outputs):
        mine = terzaghi.read_topics(path)
        theirs = _independent(path)
        counts = terzaghi.topic_counts(path)
        assert {t for t, c in counts.items() if c["read"]} == set(mine)
        checked = 0
        for topic, table in mine.items():
            msgs = theirs[topic]
            assert len(msgs) == len(table["log_time_s"]) == counts[topic]["messages"], topic
            np.testing.assert_allclose(table["log_time_s"], [t * 1e-9 for t, _ in msgs], rtol=0, atol=1e-6)
            first = msgs[0][1]
            if hasattr(first, "position") and hasattr(first, "name"):  # JointState
                for k, (_, m) in enumerate(msgs):
                    for name, p in zip(m.name, m.position):
                        assert table[f"position.{name}"][k] == p
                checked += 1
            elif hasattr(first, "wrench"):
                np.testing.assert_array_equal(table["force_z_n"], [m.wrench.force.z for _, m in msgs])
                np.testing.assert_array_equal(table["torque_y_nm"], [m.wrench.torque.y for _, m in msgs])
                checked += 1
            elif hasattr(first, "pose"):
                np.testing.assert_array_equal(table["z_m"], [m.pose.position.z for _, m in msgs])
                checked += 1
            elif hasattr(first, "lift_n"):
                for field in ("lift_n", "drag_n", "hip_torque_nm", "attack_angle_rad", "b_k", "sensor_lift_n"):
                    np.testing.assert_array_equal(table[field], [getattr(m, field) for _, m in msgs])
                np.testing.assert_array_equal(table["identified"], [float(m.identified) for _, m in msgs])
                checked += 1
            elif hasattr(first, "std_b_k"):
                np.testing.assert_array_equal(table["std_b_k"], [m.std_b_k for _, m in msgs])
                checked += 1
        assert checked >= 3, (path, sorted(mine))


def test_a_missing_topic_and_a_file_that_is_no_recording_are_refused(tmp_path):
    path = tmp_path / "s.mcap"
    with terzaghi.Recorder(path, {}) as rec:
        rec.wrench("/ft", 10**18, (1.0, 2.0, 3.0))
    with pytest.raises(terzaghi.TerzaghiError, match="no topic /nope .*its topics: /ft"):
        terzaghi.read_topics(path, ["/nope"])
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap file")
    with pytest.raises(terzaghi.TerzaghiError, match="not a recording"):
        terzaghi.read_topics(bad)
