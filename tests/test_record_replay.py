"""rerun replay of run MCAPs, and a writer killed with SIGKILL mid-run."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from helpers.recording import make_actions, rerun_cli, run_cli, write_run
from helpers.waits import Output, assert_running

from interllm.record import read_run, replay, replay_main

pytestmark = pytest.mark.skipif(rerun_cli() is None, reason="rerun CLI not installed")

REPO = Path(__file__).resolve().parents[1]
ENTITIES = ["/world/scene/walls", "/world/scene/doors", "/world/scene/furniture", "/world/scene/objects",
            "/world/robot", "/world/robot/body", "/world/paths/presumed", "/world/paths/driven",
            "/topdown/grid", "/topdown/grid_true", "/topdown/robot", "/log", "/events/planner/candidates",
            "/events/planner/costs", "/costs/navigate", "/costs/pickup", "/costs/place", "/costs/cumulative",
            "/joints/shoulder", "/joints/elbow", "/joints/wrist"]


def _entities(rrd: Path) -> dict[str, int]:
    """entity path -> rows, from `rerun rrd print` (recording store only)."""
    p = run_cli("rrd", "print", str(rrd))
    assert p.returncode == 0, p.stderr
    out: dict[str, int] = {}
    for m in re.finditer(r"with (\d+) rows \([^)]*\) - (\S+) - data columns", p.stdout):
        out[m.group(2)] = out.get(m.group(2), 0) + int(m.group(1))
    return out


def test_replay_to_rrd_verifies_and_has_entities(tmp_path):
    mcap = tmp_path / "m000.mcap"
    write_run(mcap, 6, 30)
    out = replay(mcap, save=str(tmp_path / "out.rrd"))
    assert out == [tmp_path / "out.rrd"]
    v = run_cli("rrd", "verify", str(out[0]))
    assert v.returncode == 0, v.stdout + v.stderr
    ents = _entities(out[0])
    missing = [e for e in ENTITIES if e not in ents]
    assert not missing, f"missing entities {missing}; got {sorted(ents)}"
    assert ents["/world/robot"] == 6 * 30  # one transform per trajectory sample
    assert ents["/costs/cumulative"] == 6
    assert ents["/world/paths/driven"] == 2  # navigate actions 0 and 3


def test_folder_replay_default_saves_next_to_each_run(tmp_path, capsys):
    for name in ("a", "b"):
        (tmp_path / "planner" / name).mkdir(parents=True)
        write_run(tmp_path / "planner" / name / "m000.mcap", 2, 10)
    assert replay_main([str(tmp_path)]) == 0
    for name in ("a", "b"):
        assert (tmp_path / "planner" / name / "m000.rrd").exists()
    assert replay_main([str(tmp_path / "nothing_here")]) == 2
    assert "does not exist" in capsys.readouterr().err
    with pytest.raises(ValueError, match="must be a folder"):
        replay(tmp_path, save=str(tmp_path / "one.rrd"))


def test_sigkill_mid_run_leaves_readable_prefix_and_replay_says_where(tmp_path):
    out = tmp_path / "killed.mcap"
    env = {**os.environ, "PYTHONPATH": f"{REPO}{os.pathsep}{REPO / 'tests'}"}
    # the writer flushes 4 actions, says WAITING and blocks on stdin (which the test holds open): the
    # kill lands mid-run at that known point, however slow the machine
    proc = subprocess.Popen([sys.executable, str(REPO / "tests" / "helpers" / "recording.py"), str(out), "9", "4"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    output = Output(proc)
    try:
        output.wait_for_line("stdout", "WAITING", timeout=120, what="the writer flushing 4 actions and holding")
        assert output.text("stdout").split() == ["ACTION", "0", "ACTION", "1", "ACTION", "2", "ACTION", "3",
                                                 "WAITING"]
        assert_running(proc, "the writer held mid-run", output)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    partial = out.with_name(out.name + ".partial")
    assert partial.exists() and not out.exists()
    with pytest.raises(FileNotFoundError, match="killed run left"):
        read_run(out)
    run = read_run(partial)
    assert not run.complete and run.status == "truncated"
    want = [r.to_record() for r, _ in make_actions(9, samples=200)[:4]]
    assert [a.to_record() for a in run.actions] == want  # every flushed action, exactly
    assert [p for _, p in run.events["/planner/selected"]] == [{"k": k} for k in range(4)]  # unflushed lost
    assert "complete chunks" in run.stopped_at and "4 actions" in run.stopped_at

    rrd = tmp_path / "killed.rrd"
    p = subprocess.run([sys.executable, "-c", "import sys; from interllm.record import replay_main; "
                        f"sys.exit(replay_main([{str(partial)!r}, '--save', {str(rrd)!r}]))"],
                       capture_output=True, text=True, env={**env, "CI": "1"}, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "is truncated: file ends after byte" in p.stdout
    assert run_cli("rrd", "verify", str(rrd)).returncode == 0
    assert _entities(rrd)["/costs/cumulative"] == 4
