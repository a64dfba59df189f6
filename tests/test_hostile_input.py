"""Hostile input and misuse (a 62-case fault sweep's 16 defects): each case ends in one message that
names the problem and the fix (exit 2 for bad input), nothing is written outside the run's folders
and nothing already written is lost. The cases, by number, and where each is tested:

1. a scene id that is a path (``..``, ``/``, NUL, 300 characters, device names) -- here (test_1_*)
2. two runs started in the same second share a run folder -- here (test_2_*)
3. a stage orphaned when dvc is killed before the stage's parent watch is armed -- here (test_3_*)
4. a key pasted as ``llm.api_key_env`` -- tests/test_hostile_llm.py (test_4_*)
5. one transient HTTP 500 changes the structured-output mode per worker -- test_hostile_llm.py (test_5_*)
6. a symlinked output folder is written through -- here (test_6_*)
7. NaN or string log-probabilities give tracebacks -- test_hostile_llm.py (test_7_*)
8. a cache entry of a foreign response layout -- test_hostile_llm.py (test_8_*)
9. cached failures come back after the server is fixed -- test_hostile_llm.py (test_9_*)
10. no fail-fast on sizes (10^5 objects, 10^5 rooms, 10^4 missions) -- here (test_10_*)
11. the top-level ``seed`` seeds nothing -- here (test_11_*)
12. ``interllm results diff`` on a metrics.json of the wrong shape -- here (test_12_*)
13. Retry-After ignored -- test_hostile_llm.py (test_13_*)
14. Ctrl-C prints a KeyboardInterrupt traceback from every stage -- here (test_14_*)
15. ``interllm replay`` on a FIFO named .mcap hangs -- here (test_15_*)
16. a key echoed in a server's 400 body is printed -- test_hostile_llm.py (test_16_*)
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parent))
from helpers.waits import Output, assert_running, wait_until  # noqa: E402
from procthor_houses import obj, rect, room_walls  # noqa: E402

from interllm.config import ConfigError, ExperimentConfig, from_dict  # noqa: E402
from interllm.errors import interrupted_message  # noqa: E402
from interllm.io import (  # noqa: E402
    FolderInUseError,
    UnsafePathError,
    check_inside,
    child_path,
    confine_writes,
    exclusive_folder,
    write_json,
)
from interllm.scene import generate_scene, import_procthor, scene_config  # noqa: E402
from interllm.scene.validate import SceneValidationError, validate_dict  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ORACLE = {"backend": "oracle", "proposal_mode": "oracle", "cost_inference_mode": "oracle"}
HOSTILE_IDS = ["..", ".", "../../../../../../tmp/escape", "a/b", "/etc", "x\x00y", "x" * 300, "CON", "nul.txt",
               ".hidden", "-rf", "", "a\\b", "sp ace"]


def _run(module: str, *args: str, timeout: float = 300, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", module, *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, "INTERLLM_PROGRESS": "0"}, **kw)


def _files(folder: Path) -> set[str]:
    return {p.relative_to(folder).as_posix() for p in folder.rglob("*")} if folder.exists() else set()


@pytest.fixture(scope="module")
def tiny_scene_dict() -> dict:
    return json.loads(generate_scene(scene_config("tiny", seed=3), 0).to_json())


def _house(**top) -> dict:
    """A one-room ProcTHOR house (a kitchen with a counter)."""
    return {"rooms": [{"id": "room|2", "roomType": "Kitchen", "floorPolygon": rect(0, 0, 4, 3)}],
            "walls": room_walls(2, 0, 0, 4, 3, {"S", "E", "N", "W"}), "doors": [],
            "objects": [obj("CounterTop", 2, 0, 2.0, 0.4)], **top}


# -- 1. ids that become paths ---------------------------------------------------------------------------
@pytest.mark.parametrize("bad", HOSTILE_IDS)
def test_1_a_scene_id_that_cannot_be_a_folder_name_fails_validation_at_dollar_id(tiny_scene_dict, bad):
    d = {**tiny_scene_dict, "id": bad}
    with pytest.raises(SceneValidationError) as e:
        validate_dict(d, "s.json")
    assert e.value.path == "$.id" and "it becomes a folder name (data/scenes/<id>/)" in str(e.value)
    assert len(str(e.value)) < 600  # a 300-character id is cut, not quoted whole


def test_1_a_traversing_scene_id_stops_validate_and_the_scenes_stage_writing_nothing(tmp_path, tiny_scene_dict):
    escape = tmp_path / "escape"
    bad = os.path.relpath(escape, tmp_path / "data" / "scenes")  # ../../escape
    f = tmp_path / "scene.json"
    f.write_text(json.dumps({**tiny_scene_dict, "id": bad}))
    r = _run("interllm.cli", "scene", "validate", str(f), timeout=120)
    assert r.returncode == 1 and "$.id: the scene id '../../escape'" in r.stderr and "Traceback" not in r.stderr
    (tmp_path / "params.yaml").write_text(json.dumps({"data_dir": str(tmp_path / "data"), "llm": ORACLE,
                                                      "scene": {"import_path": str(f)}}))
    r = _run("pipeline.scenes", "--params", str(tmp_path / "params.yaml"), timeout=120)
    assert r.returncode == 2 and "error: stage 'scenes':" in r.stderr and "$.id" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and not escape.exists()


def test_1_a_procthor_house_whose_id_is_a_path_is_refused_by_the_importer(tmp_path):
    house = tmp_path / "house.json"
    house.write_text(json.dumps(_house(id="../../../../escape")))
    r = _run("interllm.cli", "scene", "import-procthor", str(house), "--out", str(tmp_path / "out"), timeout=120)
    assert r.returncode == 1 and "$.id: the scene id '../../../../escape'" in r.stderr
    assert "set the house's id to a name like train_42" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "out" / "scene.json").exists()


def test_1_a_house_named_after_a_hostile_file_name_gets_a_safe_id(tmp_path):
    house = tmp_path / "..x.json"
    house.write_text(json.dumps(_house()))
    assert import_procthor(house).id == "x"


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.one_of(st.text(max_size=130), st.sampled_from(HOSTILE_IDS),
                      st.lists(st.sampled_from(["..", ".", "a", "", "/", "\x00", "CON"]), max_size=6).map("/".join)))
def test_1_property_no_name_from_input_leads_a_path_out_of_its_folder(tmp_path, name):
    """Whatever the id: the importer, validation and the stages' path builder either refuse it or
    keep the path inside the folder."""
    root = (tmp_path / "run").resolve()
    try:
        p = child_path(root, name, what="the id")
    except UnsafePathError:
        p = None
    if p is not None:
        assert p.resolve().parent == root and p.name == name
    try:
        validate_dict({"id": name}, "s.json")
    except SceneValidationError as e:
        assert e.path == "$.id" or p is not None  # refused for its id, or for the rest of the file
    try:
        scene_id = import_procthor(_house(id=name)).id
    except SceneValidationError:
        return
    assert child_path(root, scene_id).resolve().parent == root


def test_1_every_writer_refuses_a_path_outside_the_confined_folders(tmp_path):
    from interllm.llm.calllog import CallLog
    from interllm.record.recorder import McapRecorder

    run, outside = tmp_path / "run", tmp_path / "outside"
    scene = generate_scene(scene_config("tiny", seed=3), 0)
    with confine_writes(run):
        for write in (lambda: write_json(run / ".." / "outside" / "x.json", {}),
                      lambda: CallLog(outside / "calls.jsonl"),
                      lambda: McapRecorder(run / "runs" / ".." / ".." / "outside" / "m.mcap", scene),
                      lambda: child_path(run, "runs", "..", "..", "outside")):
            with pytest.raises(UnsafePathError):
                write()
        write_json(run / "inside" / "x.json", {"ok": 1})  # inside: written
    assert not outside.exists() and (run / "inside" / "x.json").is_file()


def test_1_the_missions_stage_refuses_a_mission_id_that_is_a_path(tmp_path):
    from interllm.stages.missions import MissionWorker

    worker = MissionWorker.__new__(MissionWorker)  # only the path building is under test
    worker.out_dir, worker.scenes_dir = tmp_path / "runs", tmp_path / "scenes"
    worker.scene = lambda sid: (None, {"../../../escape": None}, None, {"../../../escape": {}})
    with pytest.raises(UnsafePathError, match=r"the mission id .* it becomes a file name"):
        worker.run("inter_llm", "paper_s0000", "../../../escape")
    assert not (tmp_path / "escape.mcap").exists() and not (tmp_path / "escape.json").exists()


# -- 2. one run folder per run --------------------------------------------------------------------------
def test_2_the_default_run_and_sweep_folders_end_in_the_process_id():
    from hydra import compose, initialize_config_dir
    from hydra.core.hydra_config import HydraConfig
    from omegaconf import OmegaConf

    from pipeline._hydra import CONF_DIR, require_schema

    require_schema()
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = compose(config_name="config", return_hydra_config=True)
        HydraConfig.instance().set_config(cfg)
        run_dir, sweep_dir = OmegaConf.select(cfg, "hydra.run.dir"), OmegaConf.select(cfg, "hydra.sweep.dir")
    assert run_dir.startswith("outputs/") and run_dir.endswith(f"-{os.getpid()}")
    assert sweep_dir.startswith("multirun/") and sweep_dir.endswith(f"-{os.getpid()}")


HOLD = textwrap.dedent("""
    import sys
    from interllm.io import exclusive_folder
    with exclusive_folder(sys.argv[1]):
        print("held", flush=True)
        sys.stdin.read()  # held until the test closes the pipe (or ends): never released by a clock
""")


def _hold(folder: Path) -> tuple[subprocess.Popen, Output]:
    """A process holding ``folder`` (exclusive_folder) until its stdin is closed, once it said so."""
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(folder)], cwd=ROOT, stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out = Output(holder)
    out.wait_for_line("stdout", "held", timeout=120, what="the holder taking the run folder")
    return holder, out


def _release(holder: subprocess.Popen, out: Output) -> None:
    if holder.poll() is None:
        holder.stdin.close()
    out.finish(timeout=60, what="the holder releasing the run folder")


def test_2_a_second_run_in_a_held_folder_stops_with_the_holder_and_the_fix(tmp_path):
    holder, out = _hold(tmp_path / "run")
    try:
        assert_running(holder, "the holder of the run folder", out)
        with pytest.raises(FolderInUseError) as e:
            with exclusive_folder(tmp_path / "run"):
                pass
        assert f"is in use by process {holder.pid}" in str(e.value) and "hydra.run.dir=" in str(e.value)
    finally:
        holder.kill()
        holder.wait(timeout=30)
    with exclusive_folder(tmp_path / "run"):  # a dead holder's lock goes with it
        pass


@pytest.mark.integration
def test_2_pipeline_run_into_a_folder_another_run_holds_exits_2(tmp_path):
    holder, out = _hold(tmp_path / "run")
    try:
        assert_running(holder, "the holder of the run folder", out)
        r = _run("pipeline.run", "experiment=quick", "llm=oracle", f"hydra.run.dir={tmp_path / 'run'}")
        assert_running(holder, "the holder of the run folder, all through the second run", out)
    finally:
        _release(holder, out)
    assert r.returncode == 2 and f"is in use by process {holder.pid}" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "run" / "data").exists()


# -- 3. a stage whose dvc died before the stage was up ------------------------------------------------
# The stage's interpreter (INTERLLM_PYTHON, which pipeline/stage runs) is a gate that says it has
# started (a marker file: by then the stage script has read its parent's pid, which a shell takes at
# start-up) and then holds the stage until its parent, the stand-in for dvc, has died and the gate has
# been re-parented; only then does it exec Python. So dvc is dead before the stage's first line runs,
# on any machine, not only when the scheduler happens to let the parent exit in time.
GATE = textwrap.dedent("""\
    #!{python}
    import os, sys, time
    parent = os.getppid()
    open({ready!r}, "w").close()
    deadline = time.monotonic() + 120
    while os.getppid() == parent:
        if time.monotonic() > deadline:
            sys.exit("stage gate: the stage's parent was still alive 120 s after it started the stage")
        time.sleep(0.005)
    os.execv({python!r}, [{python!r}, *sys.argv[1:]])
""")

ORPHAN = textwrap.dedent("""
    import os, subprocess, sys, time
    params, gate, ready, log = sys.argv[1:]
    child = subprocess.Popen(["sh", "pipeline/stage", "scenes", "--params", params], stdin=subprocess.DEVNULL,
                             stdout=open(log, "w"), stderr=subprocess.STDOUT,
                             env={**os.environ, "DVC_STAGE": "scenes", "INTERLLM_PROGRESS": "0",
                                  "INTERLLM_PYTHON": gate})
    print(child.pid, flush=True)
    deadline = time.monotonic() + 120  # wait until the stage script runs its interpreter (the gate)
    while not os.path.exists(ready):
        if child.poll() is not None or time.monotonic() > deadline:
            sys.exit(f"the stage script did not start its interpreter (status {child.poll()})")
        time.sleep(0.005)
    os._exit(0)  # dvc killed
""")


def test_3_a_stage_whose_dvc_died_before_it_started_stops_without_writing(tmp_path):
    import psutil

    params, gate, ready, log = (tmp_path / "params.yaml", tmp_path / "python-gate", tmp_path / "gate-started",
                                tmp_path / "stage.log")
    params.write_text(json.dumps({"data_dir": str(tmp_path / "data"), "llm": ORACLE,
                                  "scene": {"name": "tiny", "n_rooms": 4, "n_furniture": 8, "n_objects": 12,
                                            "n_scenes": 1}}))
    gate.write_text(GATE.format(python=sys.executable, ready=str(ready)))
    gate.chmod(0o755)
    r = subprocess.run([sys.executable, "-c", ORPHAN, str(params), str(gate), str(ready), str(log)], cwd=ROOT,
                       capture_output=True, text=True, timeout=180)
    assert r.returncode == 0 and ready.exists(), (r.stdout, r.stderr)
    pid = int(r.stdout.strip())

    def running() -> bool:
        try:
            return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
        except psutil.NoSuchProcess:
            return False

    try:
        wait_until(lambda: not running(), timeout=120, what="the orphaned stage stopping after its parent died",
                   details=lambda: log.read_text() if log.exists() else "")
    finally:
        if running():
            os.kill(pid, signal.SIGKILL)
    assert not (tmp_path / "data" / "scenes").exists(), log.read_text()
    assert "Traceback" not in log.read_text() and "stage gate" not in log.read_text(), log.read_text()


def test_3_the_stages_own_children_live_on_under_dvc():
    """A missions worker imports ``pipeline`` again: it must die with the stage, not mistake dvc's pid
    (the stage's parent) for its own parent's and stop at once."""
    code = ("import subprocess, sys\nimport pipeline\n"
            "r = subprocess.run([sys.executable, '-c', 'import pipeline, time; time.sleep(0.5); print(\"alive\")'], "
            "capture_output=True, text=True)\nprint(r.stdout.strip() or r.returncode)")
    env = {**os.environ, "DVC_STAGE": "missions", "INTERLLM_STAGE_PARENT": str(os.getpid())}
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60, env=env)
    assert r.stdout.strip() == "alive", (r.stdout, r.stderr)


# -- 6. output folders that are links ---------------------------------------------------------------------
def test_6_a_symlinked_output_folder_stops_the_stage_and_the_outside_is_untouched(tmp_path, tiny_scene_dict):
    outside, data = tmp_path / "outside", tmp_path / "data"
    outside.mkdir(mode=0o755)
    outside.chmod(0o755)
    (outside / "mine.txt").write_text("keep\n")
    data.mkdir()
    (data / "scenes").symlink_to(outside, target_is_directory=True)
    f = tmp_path / "scene.json"
    f.write_text(json.dumps(tiny_scene_dict))
    (tmp_path / "params.yaml").write_text(json.dumps({"data_dir": str(data), "llm": ORACLE,
                                                      "scene": {"import_path": str(f)}}))
    r = _run("pipeline.scenes", "--params", str(tmp_path / "params.yaml"), timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert f"{data / 'scenes'} is a symbolic link to {outside.resolve()}" in r.stderr and "remove the link" in r.stderr
    assert _files(outside) == {"mine.txt"} and (outside.stat().st_mode & 0o777) == 0o755


def test_6_make_repro_refuses_linked_output_folders_before_dvc_changes_their_mode(tmp_path):
    from pipeline.check_outputs import linked_outputs

    root, outside = tmp_path / "repo", tmp_path / "outside"
    outside.mkdir()
    (root / "data").mkdir(parents=True)
    (root / "dvc.yaml").write_text((ROOT / "dvc.yaml").read_text())
    assert linked_outputs(root) == []
    (root / "data" / "report").symlink_to(outside, target_is_directory=True)
    assert linked_outputs(root) == [root / "data" / "report"]
    assert "$(PY) -m pipeline.check_outputs\n\tdvc repro" in (ROOT / "Makefile").read_text()


def test_6_a_link_deeper_in_the_tree_is_caught_at_the_write(tmp_path):
    outside, run = tmp_path / "outside", tmp_path / "run"
    outside.mkdir()
    (run / "report").mkdir(parents=True)
    (run / "report" / "figures").symlink_to(outside, target_is_directory=True)
    with confine_writes(run), pytest.raises(UnsafePathError, match="is a symbolic link to"):
        check_inside(run / "report" / "figures" / "a.png")


# -- 10. sizes -------------------------------------------------------------------------------------------
def test_10_a_scene_with_a_hundred_thousand_objects_is_refused_at_once(tiny_scene_dict):
    o = tiny_scene_dict["objects"][0]
    d = {**tiny_scene_dict, "objects": [{**o, "id": f"o{i}"} for i in range(100_000)]}
    t0 = time.monotonic()
    with pytest.raises(SceneValidationError, match=r"\$\.objects: 100000 objects: more than the 6000"):
        validate_dict(d, "big.json")
    assert time.monotonic() - t0 < 5


def test_10_a_procthor_house_with_a_hundred_thousand_rooms_is_refused_before_conversion():
    rooms = [{"id": f"room|{i}", "roomType": "Kitchen", "floorPolygon": rect(0, 0, 1, 1)} for i in range(100_000)]
    t0 = time.monotonic()
    with pytest.raises(SceneValidationError, match=r"\$\.rooms: 100000 rooms: more than the 400"):
        import_procthor(_house(rooms=rooms))
    assert time.monotonic() - t0 < 5


@pytest.mark.parametrize("overrides, key", [({"mission": {"n_missions": 10000}}, "mission.n_missions"),
                                            ({"scene": {"n_objects": 100000}}, "scene.n_objects"),
                                            ({"scene": {"n_rooms": 100000, "n_furniture": 100000}}, "scene.n_rooms"),
                                            ({"mission": {"commands_per_mission": 5000}},
                                             "mission.commands_per_mission")])
def test_10_experiment_sizes_past_the_limits_are_config_errors(overrides, key):
    with pytest.raises(ConfigError, match=rf"config key '{key}': \d+ .* is more than the \d+ the stages accept"):
        from_dict(overrides)


# -- 11. the top-level seed -------------------------------------------------------------------------------
def test_11_the_top_level_seed_offsets_every_seeded_group_but_the_bootstrap():
    cfg = from_dict({"seed": 7, "scene": {"seed": 1}}).seeded()
    assert (cfg.scene.seed, cfg.mission.seed, cfg.llm.seed, cfg.sim.seed, cfg.metrics.seed) == (8, 7, 7, 7, 0)
    base = ExperimentConfig()
    assert base.seeded() is base


def test_11_the_stages_run_the_seeded_config_and_it_draws_another_house(tmp_path):
    from interllm.stages.scenes import make_scene
    from pipeline._common import load_params

    scene = {"name": "tiny", "n_rooms": 4, "n_furniture": 8, "n_objects": 12, "n_scenes": 1}
    houses = []
    for seed in (0, 7):
        (tmp_path / "params.yaml").write_text(json.dumps({"seed": seed, "scene": scene}))
        cfg, _ = load_params(tmp_path / "params.yaml")
        houses.append(make_scene(cfg, 0).to_json())
    assert houses[0] != houses[1]


@pytest.mark.parametrize("seed", [-1, 2**70])
def test_11_a_seed_out_of_range_is_a_config_error(seed):
    with pytest.raises(ConfigError, match=r"config key 'seed': must be in \[0, 2147483647\]"):
        from_dict({"seed": seed})


# -- 12. results diff on a metrics.json of another shape ----------------------------------------------
@pytest.mark.parametrize("current", ["[]", '{"planners": []}', '{"planners": {"x": 3}}'])
def test_12_results_diff_on_a_metrics_file_of_the_wrong_shape_names_it(tmp_path, current):
    repo = tmp_path / "repo"
    (repo / "data" / "metrics").mkdir(parents=True)
    metrics = repo / "data" / "metrics" / "metrics.json"
    metrics.write_text('{"planners": {"inter_llm": {"m_overall": 1.0}}}')
    git = ["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@t"]
    subprocess.run([*git[:3], "init", "-q"], check=True)
    subprocess.run([*git, "add", "."], check=True)
    subprocess.run([*git, "commit", "-qm", "m"], check=True)
    metrics.write_text(current)
    r = _run("interllm.cli", "results", "diff", "--repo", str(repo), timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert f"results diff: {metrics}" in r.stderr and "dvc repro aggregate" in r.stderr


# -- 14. Ctrl-C -----------------------------------------------------------------------------------------------
# The scenes stage, as `python -m pipeline.scenes` runs it, held at the start of its first scene until
# the test's Ctrl-C: it says so on stdout, and stays there. A stage left to run may be done before the
# signal lands (on a loaded machine), and a test of that measures the scheduler, not the handler.
HELD_STAGE = textwrap.dedent("""
    import runpy, signal, sys, time
    from interllm.stages import scenes

    # Ctrl-C as an interactive terminal delivers it: a shell that starts a job in the background (as
    # some CI runners start the suite) leaves SIGINT ignored in every child, and Python keeps it so.
    signal.signal(signal.SIGINT, signal.default_int_handler)

    def held(*args, **kw):
        print("in the first scene", flush=True)
        time.sleep(600)  # until the test's SIGINT (600 s: a test that sends none still ends)
        raise SystemExit("held stage: no SIGINT within 600 s")

    assert hasattr(scenes, "make_scene"), "interllm.stages.scenes.make_scene is gone: hold the stage elsewhere"
    scenes.make_scene = held
    sys.argv = ["pipeline.scenes", *sys.argv[1:]]
    runpy.run_module("pipeline.scenes", run_name="__main__", alter_sys=True)
""")


def test_14_ctrl_c_in_a_stage_is_one_line_and_status_130(tmp_path):
    (tmp_path / "params.yaml").write_text(json.dumps({
        "data_dir": str(tmp_path / "data"), "llm": ORACLE,
        "scene": {"name": "tiny", "n_rooms": 4, "n_furniture": 8, "n_objects": 12, "n_scenes": 2},
        "jobs": 1}))  # held in this process: a worker process would not see the held make_scene
    proc = subprocess.Popen([sys.executable, "-c", HELD_STAGE, "--params", str(tmp_path / "params.yaml")],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "INTERLLM_PROGRESS": "0"})
    out = Output(proc)
    try:
        out.wait_for_line("stdout", "in the first scene", timeout=120, what="the scenes stage starting its work")
        assert_running(proc, "the scenes stage held in its first scene", out)
        proc.send_signal(signal.SIGINT)
        _, err = out.finish(timeout=60, what="the scenes stage after Ctrl-C")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=30)
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == ["error: " + interrupted_message("stage 'scenes'")], err  # one line
    assert "Traceback" not in err


WORKER_INIT_THEN_CTRL_C = """
import os, signal, sys, time
from interllm.stages import missions, scenes
from interllm.stages.workers import leave_ctrl_c_to_parent
{init}
os.kill(os.getpid(), signal.SIGINT)
time.sleep(2)
print("went on")
"""


@pytest.mark.parametrize("init", ["leave_ctrl_c_to_parent()", "scenes._init_worker(os.getppid())"])
@pytest.mark.parametrize("parent_ignores", [False, True])
def test_14_a_worker_leaves_ctrl_c_to_its_parent_and_keeps_an_ignored_one(init, parent_ignores):
    """A worker initializer makes Ctrl-C exit 130 with no traceback (the parent says what stopped);
    when the stage was started with SIGINT ignored (``nohup ... &``), the worker ignores it too and
    goes on with its parent."""
    code = WORKER_INIT_THEN_CTRL_C.format(init=init)
    disposition = signal.SIG_IGN if parent_ignores else signal.SIG_DFL  # set either way: pytest may run under nohup

    def preexec():
        signal.signal(signal.SIGINT, disposition)
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60,
                       preexec_fn=preexec)
    assert "Traceback" not in r.stderr, r.stderr
    if parent_ignores:
        assert r.returncode == 0 and "went on" in r.stdout, (r.returncode, r.stderr)
    else:
        assert r.returncode == 130 and "went on" not in r.stdout, (r.returncode, r.stderr)


def test_14_the_mission_workers_set_up_ctrl_c_with_the_shared_initializer(monkeypatch):
    """``missions._init_worker`` calls ``leave_ctrl_c_to_parent`` (its other set-up needs a config
    and a call-log queue, so it is checked here in process)."""
    from interllm.stages import missions

    called = []
    monkeypatch.setattr(missions, "die_with_parent", lambda parent: None)
    monkeypatch.setattr(missions, "leave_ctrl_c_to_parent", lambda: called.append(True))
    monkeypatch.setattr(missions, "MissionWorker", lambda *a: None)

    class _Ids:
        def get(self, timeout):
            return "log"
    missions._init_worker(0, _Ids(), None, None, None, None, {})
    assert called == [True]


# -- 15. a FIFO named .mcap ---------------------------------------------------------------------------------
def test_15_replay_of_a_fifo_is_a_message_not_a_hang(tmp_path):
    fifo = tmp_path / "m000.mcap"
    os.mkfifo(fifo)
    r = _run("interllm.cli", "replay", str(fifo), timeout=60)
    assert r.returncode == 2 and "is not a regular file" in r.stderr and "Traceback" not in r.stderr


def test_15_read_run_refuses_a_fifo(tmp_path):
    fifo = tmp_path / "m000.mcap"
    os.mkfifo(fifo)
    code = ("import sys\nfrom interllm.record.reader import RunLogFormatError, read_run\n"
            "try:\n    read_run(sys.argv[1])\nexcept RunLogFormatError as e:\n    print(e)")
    r = subprocess.run([sys.executable, "-c", code, str(fifo)], cwd=ROOT, capture_output=True, text=True,
                       timeout=60)  # in a process of its own: without the check, the open blocks for ever
    assert "is not a regular file" in r.stdout, r.stderr
