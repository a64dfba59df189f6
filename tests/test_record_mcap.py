"""McapRecorder + read_run: channels, counts, exact round-trips, schemas, truncation, errors."""

from __future__ import annotations

import json
import math
from collections import defaultdict

import jsonschema
import numpy as np
import pytest
from foxglove_schemas_protobuf.Grid_pb2 import Grid
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from helpers.recording import JOINTS, make_actions, make_grids, make_scene, rerun_cli, run_cli, write_run
from mcap.reader import make_reader

from interllm.record import ACTION_SCHEMA, McapRecorder, read_run

N, S = 6, 40  # actions, samples per trajectory


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    """One run of N actions with S trajectory samples each."""
    path = tmp_path_factory.mktemp("rec") / "m000.mcap"
    acts, extra = write_run(path, N, S)
    return path, acts, extra


def _raw(path):
    with open(path, "rb") as f:
        r = make_reader(f)
        return [(ch.topic, sch, m) for sch, ch, m in r.iter_messages(log_time_order=False)], r.get_summary()


def test_file_is_renamed_and_partial_gone(run_file):
    path, _, _ = run_file
    assert path.exists()
    assert not path.with_name(path.name + ".partial").exists()


@pytest.mark.skipif(rerun_cli() is None, reason="rerun CLI not installed")
def test_rerun_mcap_check_passes(run_file):
    path, _, _ = run_file
    p = run_cli("mcap", "check", str(path))
    assert p.returncode == 0, p.stdout + p.stderr
    topics = [ln.split()[3] for ln in p.stdout.splitlines() if ln.split()[:1] in (["ok"], ["warn"], ["error"])]
    assert "/tf" in topics and "/actions" in topics
    for ln in p.stdout.splitlines():
        if ln.split()[:1] in (["warn"], ["error"]):
            pytest.fail(f"rerun mcap check reports: {ln}")


def test_channels_schemas_and_counts(run_file):
    path, acts, extra = run_file
    run = read_run(path)
    assert run.complete and run.stopped_at is None and run.status == "ok"
    n_nav = sum(1 for r, _ in acts if r.action.kind == "navigate")
    expected = {"/scene": 1, "/scene/objects": 1, "/grid/presumed": 1, "/grid/true": 1, "/tf": N * S, "/joint_states": N * S,
                "/path/presumed": n_nav, "/path/driven": n_nav, "/actions": N, "/log": N,
                "/planner/candidates": N, "/planner/costs": N}
    assert run.counts == expected
    assert run.summary_counts == expected
    msgs, summary = _raw(path)
    enc = {ch.topic: (summary.schemas[ch.schema_id].name, ch.message_encoding) for ch in summary.channels.values()}
    assert enc["/tf"] == ("foxglove.FrameTransforms", "protobuf")
    assert enc["/scene"] == ("foxglove.SceneUpdate", "protobuf")
    assert enc["/grid/true"] == ("foxglove.Grid", "protobuf")
    assert enc["/path/driven"] == ("foxglove.PosesInFrame", "protobuf")
    assert enc["/log"] == ("foxglove.Log", "protobuf")
    assert enc["/joint_states"] == ("interllm.JointStates", "protobuf")
    assert enc["/actions"][1] == enc["/planner/candidates"][1] == "json"


def test_actions_round_trip_exactly(run_file):
    path, acts, _ = run_file
    run = read_run(path)
    assert [a.to_record() for a in run.actions] == [r.to_record() for r, _ in acts]
    assert run.contexts == [ctx for _, ctx in acts]
    for got, (want, _) in zip(run.actions, acts, strict=True):
        tr, wt = got.trajectory, want.trajectory
        np.testing.assert_allclose(tr.t, wt.t, rtol=0, atol=0.6e-9)  # log time is whole ns
        np.testing.assert_allclose(tr.base, wt.base, atol=1e-12)
        np.testing.assert_array_equal(tr.joints, wt.joints)
        assert tr.joint_names == JOINTS


def test_action_messages_validate_against_schema_and_times(run_file):
    path, acts, _ = run_file
    msgs, summary = _raw(path)
    schema_json = {ch.topic: json.loads(summary.schemas[ch.schema_id].data)
                   for ch in summary.channels.values() if ch.message_encoding == "json"}
    assert schema_json["/actions"] == ACTION_SCHEMA
    jsonschema.Draft202012Validator.check_schema(ACTION_SCHEMA)
    recs = [(json.loads(m.data), m.log_time) for t, _, m in msgs if t == "/actions"]
    for (d, log_time), (r, _) in zip(recs, acts, strict=True):
        jsonschema.validate(d, ACTION_SCHEMA)
        assert log_time == round((r.t_start + r.time) * 1e9)
        assert d["n_samples"] == S
    bad = {**recs[0][0], "kind": "teleport"}
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, ACTION_SCHEMA)
    last = defaultdict(int)
    for topic, _, m in msgs:  # log_time non-decreasing per channel, publish_time == log_time
        assert m.log_time >= last[topic]
        assert m.publish_time == m.log_time
        last[topic] = m.log_time


def test_scene_grids_metadata_events(run_file):
    path, _, extra = run_file
    run = read_run(path)
    scene = make_scene()
    assert run.scene.to_dict() == scene.to_dict()
    for name, g in make_grids(scene).items():
        np.testing.assert_array_equal(run.grids[name].occupied, g.occupied)
        assert run.grids[name].resolution == g.resolution and run.grids[name].origin == g.origin
    assert all(isinstance(v, str) for v in run.metadata["run"].values())
    assert run.run["config"] == extra["meta"]["config"] and run.run["seed"] == 11
    assert run.run["git_commit"] == "abc123"
    assert run.metadata["end"]["n_actions"] == str(N)
    by_topic = defaultdict(list)
    for topic, t, payload in extra["events"]:
        by_topic[topic].append((t, json.loads(json.dumps(payload, default=float))))
    assert run.events == dict(by_topic)
    assert [m for _, _, m in run.logs] == [f"executing {r.action}" for r, _ in make_actions(N, S)]
    assert {lv for _, lv, _ in run.logs} == {"info"}


def test_scene_update_cubes_by_hand(run_file):
    path, _, _ = run_file
    msgs, _ = _raw(path)
    su = SceneUpdate.FromString(next(m.data for t, _, m in msgs if t == "/scene"))
    ents = {e.id: e for e in su.entities}
    # 2 walls + 1 door leaf (door_2 fully open has none) + 2 furniture; objects are on /scene/objects
    assert len(ents) == 5 and "door/door_2" not in ents
    objs = SceneUpdate.FromString(next(m.data for t, _, m in msgs if t == "/scene/objects"))
    book = {e.id: e for e in objs.entities}["object/book_1"]
    assert book.frame_id == "world" and book.frame_locked
    c = book.cubes[0]
    assert (c.pose.position.x, c.pose.position.y, c.pose.position.z) == (6.4, 3.1, 0.52)
    assert (round(c.size.x, 6), round(c.size.y, 6), round(c.size.z, 6)) == (0.2, 0.15, 0.04)
    bed = ents["furniture/bed_1"].cubes[0]
    assert (bed.pose.position.x, bed.pose.position.y, bed.pose.position.z) == (6.5, 3.0, 0.25)
    assert (bed.size.x, bed.size.y, bed.size.z) == (1.5, 1.8, 0.5)
    # wall_1 runs along +y from (4,0) to (4,1.5): centre (4, 0.75), yaw 90°, length 1.5 + thickness
    w = ents["wall/wall_1"].cubes[0]
    assert math.isclose(w.pose.position.y, 0.75) and math.isclose(w.size.x, 1.6)
    assert math.isclose(2 * math.atan2(w.pose.orientation.z, w.pose.orientation.w), math.pi / 2)
    # door_1 half open, hinge low, axis y: leaf covers y in [1.5, 2.0] at x=4
    d = ents["door/door_1"].cubes[0]
    assert math.isclose(d.pose.position.y, 1.75) and math.isclose(d.size.x, 0.5)
    g = Grid.FromString(next(m.data for t, _, m in msgs if t == "/grid/presumed"))
    assert g.column_count * (len(g.data) // g.row_stride) == len(g.data)


def test_deterministic_bytes(tmp_path):
    write_run(tmp_path / "a.mcap", 3, 20)
    write_run(tmp_path / "b.mcap", 3, 20)
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()


def test_truncated_prefixes_read_up_to_last_complete_chunk(tmp_path):
    path = tmp_path / "full.mcap"
    acts, _ = write_run(path, N, S, chunk_size=2048)
    data = path.read_bytes()
    full = [r.to_record() for r, _ in acts]
    n_seen = []
    for frac in (0.15, 0.35, 0.55, 0.8, 0.97):
        cut = tmp_path / f"cut{frac}.mcap"
        cut.write_bytes(data[:int(len(data) * frac)])
        run = read_run(cut)
        assert not run.complete
        # the "end" record precedes the summary: a cut inside the summary still has it
        assert run.status == ("ok" if "end" in run.metadata else "truncated")
        assert "file ends after byte" in run.stopped_at and "complete chunks" in run.stopped_at
        got = [a.to_record() for a in run.actions]
        assert got == full[:len(got)]  # a prefix, exactly
        assert run.counts.get("/tf", 0) >= S * len(got)
        assert run.scene is not None and run.run["seed"] == 11
        n_seen.append(len(got))
    assert n_seen == sorted(n_seen) and n_seen[-1] == N and n_seen[0] < N


def test_error_in_run_still_finishes_file(tmp_path):
    path = tmp_path / "err.mcap"
    scene = make_scene()
    with pytest.raises(RuntimeError):
        with McapRecorder(path, scene, {}) as rec:
            rec.action(*make_actions(1, 5)[0])
            raise RuntimeError("planner crashed")
    run = read_run(path)
    assert run.complete and run.status == "error" and "planner crashed" in run.metadata["end"]["error"]
    assert len(run.actions) == 1


def test_bad_input_errors(tmp_path):
    rec = McapRecorder(tmp_path / "x.mcap", make_scene(), {})
    with pytest.raises(ValueError, match="choose one of"):
        rec.log(0.0, "loud", "x")
    with pytest.raises(ValueError, match="reserved"):
        rec.event("/actions", 0.0, {})
    with pytest.raises(ValueError, match="starting with '/'"):
        rec.event("planner", 0.0, {})
    with pytest.raises(ValueError, match=">= 0"):
        rec.event("/planner/x", -1.0, {})
    with pytest.raises(TypeError, match="JSON"):
        rec.event("/planner/x", 0.0, {"o": object()})
    rec.close()
    with pytest.raises(RuntimeError, match="closed"):
        rec.log(0.0, "info", "late")
    with pytest.raises(ValueError, match="compression"):
        McapRecorder(tmp_path / "y.mcap", make_scene(), {}, compression="gzip")
    with pytest.raises(FileNotFoundError, match="no MCAP"):
        read_run(tmp_path / "missing.mcap")
    (tmp_path / "junk.mcap").write_bytes(b"not an mcap file")
    with pytest.raises(ValueError, match="not an MCAP"):
        read_run(tmp_path / "junk.mcap")


@pytest.mark.parametrize("closed", [True, False])
def test_a_log_from_an_older_version_is_named_as_such_not_as_truncated(tmp_path, closed):
    """Joint states were JSON before they were protobuf: say so, complete or not."""
    from mcap.writer import Writer

    from interllm.record.reader import RunLogFormatError

    path = tmp_path / "old.mcap"
    with open(path, "wb") as f:
        w = Writer(f, use_chunking=closed)  # unchunked: the message is on disk before any finish()
        w.start()
        sid = w.register_schema("joint_states", "jsonschema", b"{}")
        ch = w.register_channel("/joint_states", "json", sid)
        w.add_message(ch, log_time=2_000_000_000, publish_time=2_000_000_000, sequence=0,
                      data=b'{"action": 0, "names": ["j"], "positions": [0.5]}')
        if closed:
            w.finish()  # else: a killed run, no summary; the streaming read handles it
    with pytest.raises(RunLogFormatError, match=r"old\.mcap: /joint_states at t=2\.000 s is JSON.*"
                                                r"dvc repro --force missions"):
        read_run(path)


def test_joint_states_are_the_canonical_protobuf_of_each_sample(run_file):
    """The array-built messages (record/wire.py) are exactly SerializeToString() of each sample."""
    from interllm.record.topics import JointStates

    path, acts, _ = run_file
    msgs, _ = _raw(path)
    js = [m.data for t, _, m in msgs if t == "/joint_states"]
    samples = [(k, b, j) for k, (r, _) in enumerate(acts)
               for b, j in zip(r.trajectory.base.tolist(), r.trajectory.joints.tolist(), strict=True)]
    assert len(js) == len(samples)
    for data, (k, b, j) in zip(js, samples, strict=True):
        assert data == JointStates(action=k, base=b, names=list(JOINTS), positions=j).SerializeToString()
