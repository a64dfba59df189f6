"""Bad input and bad environments: each case ends in one message that names the problem and the
fix, within a bound, and loses nothing already written (issue: results a stranger can trust).

Protocol cases run against a fake Ollama server on 127.0.0.1 (tests/helpers/ollama_server.py)."""

from __future__ import annotations

import json
import logging
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from helpers.files import make_read_only, undo_read_only  # noqa: E402
from helpers.ollama_server import FakeOllama, free_port  # noqa: E402

from interllm.config import ConfigError, ExperimentConfig, LLMConfig, from_dict  # noqa: E402
from interllm.llm import LLMRequest, Message, make_client  # noqa: E402
from interllm.llm.deadline import DeadlineExceeded  # noqa: E402
from interllm.llm.errors import LLMQualityError  # noqa: E402
from interllm.llm.ollama_backend import OllamaProtocolError  # noqa: E402
from interllm.llm.testing import DeterministicBackend  # noqa: E402
from interllm.scene import SceneValidationError, generate_scene, load_scene_file, scene_config  # noqa: E402
from interllm.scene.generator import SceneGenerationError  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = {"type": "object", "properties": {"a": {"type": "integer"}}, "required": ["a"]}
REQ = LLMRequest(purpose="candidates", messages=(Message("user", "Give a."),), schema=SCHEMA)


def _cli(*args, cwd=ROOT, env=None, timeout=120):
    return subprocess.run([sys.executable, "-m", "interllm.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, **(env or {})})


def _ollama_cfg(host: str, tmp_path: Path, **kw) -> LLMConfig:
    base = dict(backend="ollama", model="fixture-model", host=host, cache_dir=str(tmp_path / "cache"),
                timeout_s=10.0, proposal_mode="generate", cost_inference_mode="generate")
    return LLMConfig(**{**base, **kw})


# -- a broken model fails loudly --------------------------------------------------------------------
@pytest.mark.integration
def test_a_model_that_answers_garbage_stops_the_candidates_stage(tmp_path):
    from interllm.stages.candidates import run_candidates
    from interllm.stages.scenes import run_scenes

    with FakeOllama(fault="garbage") as srv:
        cfg = ExperimentConfig(scene=scene_config("tiny"), llm=_ollama_cfg(srv.host, tmp_path))
        cfg.mission.n_missions, cfg.mission.include_paper_mission = 2, False
        run_scenes(cfg, tmp_path / "scenes")
        out = tmp_path / "candidates"
        out.mkdir()
        (out / "earlier.json").write_text('{"kept": true}\n')  # written by an earlier run
        t0 = time.monotonic()
        with pytest.raises(LLMQualityError) as e:
            run_candidates(cfg, tmp_path / "scenes", out)
    msg = str(e.value)
    assert "backend 'ollama'" in msg and "fixture-model" in msg and "llm.max_failure_share=0.05" in msg
    assert "'I think {banana'" in msg and "(100%)" in msg
    assert time.monotonic() - t0 < 60
    assert (out / "earlier.json").read_text() == '{"kept": true}\n'  # nothing already written is lost
    assert sorted(p.name for p in out.iterdir()) == ["earlier.json", "llm_calls.jsonl"]  # no candidates written
    calls = [json.loads(x) for x in (out / "llm_calls.jsonl").read_text().splitlines()]
    assert calls and all(c["error"] for c in calls) and calls[0]["answer"] == "I think {banana"


def test_the_failure_share_stops_a_client_early_and_lets_a_few_failures_pass(tmp_path):
    answers = iter(["nope"] * 3 + ['{"a": 1}'] * 100)
    good = make_client(LLMConfig(cache_dir=str(tmp_path / "c1"), cache_mode="off", repair_retries=0),
                       backend=DeterministicBackend(generate_fn=lambda *a: next(answers)))
    fails = 0
    for _ in range(60):  # 3 failures in 60 calls: 5%, not above the bound
        try:
            good.complete(REQ)
        except Exception:  # noqa: BLE001
            fails += 1
    assert fails == 3  # 3 of 60 = 5%: tolerated
    bad = make_client(LLMConfig(cache_dir=str(tmp_path / "c2"), cache_mode="off", repair_retries=0),
                      backend=DeterministicBackend(generate_fn=lambda *a: "I think {banana"))
    with pytest.raises(LLMQualityError, match=r"stopping early: 20 of 20 LLM calls \(100%\)"):
        for _ in range(100):
            try:
                bad.complete(REQ)
            except LLMQualityError:
                raise
            except Exception:  # noqa: BLE001 - the single failures before the share is judged
                pass


def test_failed_calls_are_counted_in_the_metrics(tmp_path):
    from interllm.metrics.compute import call_log_counts

    log = tmp_path / "llm_calls.jsonl"
    rows = [{"planner": "inter_llm", "error": None}, {"planner": "inter_llm", "error": "bad JSON"},
            {"planner": "sayplan", "error": "HTTP 500"}]
    log.write_text("".join(json.dumps(r) + "\n" for r in rows) + '{"planner": "cut by a cra')
    c = call_log_counts(log)
    assert (c["calls"], c["failed"], c["failed_by_planner"]) == (3, 2, {"inter_llm": 1, "sayplan": 1})


# -- the project's interpreter, whatever PATH says ------------------------------------------------
def test_stages_run_with_the_project_interpreter_whatever_path_says(tmp_path):
    fake = tmp_path / "bin"
    fake.mkdir()
    (fake / "python").write_text("#!/bin/sh\necho 'the wrong python' >&2\nexit 3\n")
    (fake / "python").chmod(0o755)
    env = {k: v for k, v in os.environ.items() if k != "INTERLLM_PYTHON"}
    env["PATH"] = f"{fake}:/usr/bin:/bin"
    if not (ROOT / ".venv" / "bin" / "python").exists():
        env["INTERLLM_PYTHON"] = sys.executable  # a checkout without .venv (the tests' own interpreter)
    r = subprocess.run(["sh", "pipeline/stage", "scenes", "--help"], cwd=ROOT, env=env, capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert "DVC stage 'scenes'" in r.stdout and "wrong python" not in r.stderr
    # and with no interpreter to find, it says how to get one
    env.pop("INTERLLM_PYTHON", None)
    shutil.copy(ROOT / "pipeline" / "stage", tmp_path / "stage")
    r = subprocess.run(["sh", str(tmp_path / "stage"), "scenes"], cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 2 and "make install" in r.stderr and "INTERLLM_PYTHON" in r.stderr


# -- killed runs leave nothing running -----------------------------------------------------------
# The workers are held at the start of a run (tests/helpers/held_runs.py, imported as planner.modules),
# its run log open, each after writing a marker file: the test kills the stage when both are up and
# writing, and cannot come too late on a slow machine (the runs would be over) or too early.
KILL_SCRIPT = """
import sys
from interllm.stages.candidates import run_candidates
from interllm.stages.missions import run_missions
from interllm.stages.scenes import run_scenes
from pipeline._hydra import compose, to_config
root = sys.argv[1]
cfg = to_config(compose(["jobs=2", "scene.n_scenes=1", "mission.limit_missions=2", "planner.modules=[helpers.held_runs]",
                         "llm.cache_mode=replay", "llm.cache_dir=" + sys.argv[2], "benchmark_dir=" + sys.argv[3]]))
run_scenes(cfg, root + "/scenes")
run_candidates(cfg, root + "/scenes", root + "/candidates")
print("missions", flush=True)
run_missions(cfg, root + "/scenes", root + "/candidates", root + "/runs")
"""


def _cmdline(p) -> str:
    """A process's command line, or "" when it ended meanwhile (a short-lived child such as git)."""
    import psutil

    try:
        return " ".join(p.cmdline())
    except (psutil.NoSuchProcess, psutil.ZombieProcess, psutil.AccessDenied):
        return ""


def _tree_state(d: Path) -> dict:
    return {str(p): (p.stat().st_size, p.stat().st_mtime_ns) for p in d.rglob("*") if p.is_file()}


@pytest.mark.integration
def test_a_killed_two_worker_run_leaves_nothing_running(tmp_path):
    import psutil
    from helpers.held_runs import HELD_DIR_ENV
    from helpers.waits import Output, assert_running, wait_until

    held = tmp_path / "held"
    held.mkdir()
    proc = subprocess.Popen([sys.executable, "-c", KILL_SCRIPT, str(tmp_path), str(ROOT / "data" / "llm_cache"),
                             str(ROOT / "data" / "benchmarks")],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "INTERLLM_PROGRESS": "0", HELD_DIR_ENV: str(held),
                                 "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT / "tests"),
                                                                             os.environ.get("PYTHONPATH")]))})
    out = Output(proc)
    parent = psutil.Process(proc.pid)
    try:
        out.wait_for_line("stdout", "missions", timeout=300, what="the scenes and candidates stages")
        wait_until(lambda: len(list(held.iterdir())) >= 2, timeout=120,
                   what="two missions workers starting a run", gone=lambda: proc.poll() is not None,
                   details=lambda: out.text("stderr"))
        assert_running(proc, "the missions stage with its two workers held in a run", out)
        children = parent.children(recursive=True)
        workers = {int(p.name) for p in held.iterdir()}
        assert workers <= {c.pid for c in children if c.is_running()}, (workers, [_cmdline(c) for c in children])
        assert list((tmp_path / "runs").rglob("*.mcap.partial")), "the held runs have no open run log"
    finally:
        proc.kill()
        proc.wait(timeout=30)
    gone, alive = psutil.wait_procs(children, timeout=30)
    assert not alive, f"still running after the parent was killed: {[_cmdline(p) for p in alive]}"
    before = _tree_state(tmp_path / "runs")
    time.sleep(1.0)
    assert _tree_state(tmp_path / "runs") == before  # nobody writes into data/runs any more


# -- every wait is bounded ---------------------------------------------------------------------------
def test_a_server_that_trickles_bytes_hits_the_whole_call_deadline(tmp_path):
    with FakeOllama(fault="trickle", trickle_s=30) as srv:
        client = make_client(_ollama_cfg(srv.host, tmp_path, timeout_s=1.0))
        t0 = time.monotonic()
        with pytest.raises(DeadlineExceeded) as e:
            client.complete(REQ)
        took = time.monotonic() - t0
    assert took < 5.0, f"the call took {took:.1f} s against a 1 s deadline"
    assert f"{srv.host}/api/chat" in str(e.value) and "llm.timeout_s=1" in str(e.value)
    assert not any((tmp_path / "cache").rglob("*.json")) or json.loads(
        (tmp_path / "cache" / "models.json").read_text())  # no half-written entry, only the model pin


@pytest.mark.embedded
def test_the_embedded_model_honours_the_timeout(tmp_path):
    from interllm.llm.embedded import EmbeddedBackend
    from interllm.llm.types import LLMOptions

    be = EmbeddedBackend(LLMConfig(timeout_s=0.05, n_threads=1))
    _ = be.llm  # load outside the deadline
    long = " ".join(f"item{i}" for i in range(1200))  # about 5,500 tokens: seconds of prompt evaluation
    t0 = time.monotonic()
    with pytest.raises(DeadlineExceeded, match=r"embedded model's generation took longer than llm.timeout_s=0.05"):
        be.generate((Message("user", long),), None, LLMOptions(max_tokens=200), seed=1)
    assert time.monotonic() - t0 < 2.0
    with pytest.raises(DeadlineExceeded, match="scoring of 2 continuations"):
        be.score(long, [" a", " b"])
    be.cfg.timeout_s = 60.0  # the backend still works after a deadline, from a consistent KV state
    assert be.score("A cat sat on the", [" mat", " moon"]).raw[0] > -20
    be.close()


def test_impossible_scene_sizes_are_refused_up_front_with_numbers_that_fit():
    cfg = scene_config("tiny")
    cfg.n_objects = 5000  # under the size limit (SCENE_LIMITS), over what 8 pieces hold
    t0 = time.monotonic()
    with pytest.raises(SceneGenerationError, match=r"scene.n_objects=5000 cannot fit on scene.n_furniture=8 "
                                                     r"pieces: at most \d+ objects would .* lower scene.n_objects"):
        generate_scene(cfg)
    cfg.n_objects = 2000  # below the geometric bound, far above what this house holds
    with pytest.raises(SceneGenerationError, match=r"surfaces of the 8 furniture .* were full after \d+ objects"):
        generate_scene(cfg)
    assert time.monotonic() - t0 < 30


# -- validation on both entry points -------------------------------------------------------------
@pytest.mark.parametrize("params, message", [
    ({"planner": {"M": "abc"}}, "config key 'planner.M' (in params.yaml) must be an integer, got 'abc'"),
    ({"planner": {"M": 3.5}}, "3.5 is not a whole number"),
    ({"planner": {"names": "inter_llm"}}, "write a list, e.g. -S 'planner.names=[inter_llm]'"),
    ({"planner": {"MM": 3}}, "config key 'planner.MM' (in params.yaml) is unknown (did you mean planner.M?)"),
    ({"llm": {"max_failure_share": 2}}, "llm.max_failure_share"),
    ({"verbose": "yes"}, "config key 'verbose' (in params.yaml) must be true or false"),
])
def test_params_yaml_values_are_type_checked(params, message):
    with pytest.raises(ConfigError) as e:
        from_dict(params, source="params.yaml")
    assert message in str(e.value)


def test_a_stage_names_the_bad_key_and_says_what_dvc_removed(tmp_path):
    """The note on restoring the outputs only where the DVC cache holds them (tests/test_bad_input.py
    checks both cases)."""
    from pipeline._common import cached_outputs

    (tmp_path / "params.yaml").write_text("planner:\n  M: abc\n")
    r = subprocess.run([sys.executable, "-m", "pipeline.scenes", "--params", str(tmp_path / "params.yaml")],
                       cwd=ROOT, capture_output=True, text=True, timeout=120,
                       env={**os.environ, "DVC_STAGE": "scenes"})
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "config key 'planner.M'" in r.stderr and "params.yaml" in r.stderr
    assert ("`dvc checkout scenes` restores them" in r.stderr) == cached_outputs(ROOT, "scenes")


def test_hydra_plus_key_additions_are_rejected():
    before = (ROOT / "params.yaml").read_bytes()
    r = subprocess.run([sys.executable, "-m", "pipeline.params", "+planner.MM=3"], cwd=ROOT, capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2 and "config key 'planner.MM'" in r.stderr and "did you mean planner.M" in r.stderr
    assert (ROOT / "params.yaml").read_bytes() == before  # untouched


@pytest.fixture(scope="module")
def tiny_scene():
    return json.loads(generate_scene(scene_config("tiny", seed=3), 0).to_json())


def test_overlapping_rooms_are_reported_as_overlapping(tmp_path, tiny_scene):
    d = json.loads(json.dumps(tiny_scene))
    (x0, y0), (x1, y1) = d["rooms"][0]["polygon"][0], d["rooms"][0]["polygon"][2]
    d["rooms"][1]["polygon"] = [[x0 + 1, y0 + 1], [x1 + 1, y0 + 1], [x1 + 1, y1 + 1], [x0 + 1, y1 + 1]]
    f = tmp_path / "overlap.json"
    f.write_text(json.dumps(d))
    with pytest.raises(SceneValidationError, match=r"\$\.rooms\[1\]\.polygon: room .* overlaps room .* by about"):
        load_scene_file(f)
    load_scene_file_ok = tmp_path / "ok.json"  # rooms sharing a wall are fine
    load_scene_file_ok.write_text(json.dumps(tiny_scene))
    load_scene_file(load_scene_file_ok)


# -- tracebacks become messages ----------------------------------------------------------------------
def test_non_utf8_bytes_in_a_scene_file_name_the_byte(tmp_path, tiny_scene):
    f = tmp_path / "latin1.json"
    f.write_bytes(json.dumps(tiny_scene).encode()[:40] + b"\xe9t\xe9" + json.dumps(tiny_scene).encode()[40:])
    r = _cli("scene", "validate", str(f))
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert f"{f}: $: byte 40: not UTF-8 text" in r.stderr and "save the file as UTF-8" in r.stderr


def test_deeply_nested_json_is_a_message_not_a_recursion_error(tmp_path):
    f = tmp_path / "brackets.json"
    f.write_bytes(b"[" * 50_000_000)
    r = _cli("scene", "validate", str(f))
    assert r.returncode == 1 and "RecursionError" not in r.stderr and "nested too deeply" in r.stderr


def test_procthor_files_with_bad_bytes_or_wrong_types_name_the_place(tmp_path):
    f = tmp_path / "house.json"
    f.write_bytes(b'{"rooms": [\xff]}')
    r = _cli("scene", "import-procthor", str(f), "--out", str(tmp_path / "out"))
    assert r.returncode == 1 and "byte 11: not UTF-8" in r.stderr
    house = {"rooms": [{"id": "r0", "roomType": "Kitchen",
                        "floorPolygon": [{"x": 0, "z": 0}, {"x": "four", "z": 0}, {"x": 4, "z": 4}]}]}
    f.write_text(json.dumps(house))
    r = _cli("scene", "import-procthor", str(f), "--out", str(tmp_path / "out"))
    assert r.returncode == 1 and "Traceback" not in r.stderr and "$.rooms[0]" in r.stderr
    assert not (tmp_path / "out").exists()


def test_a_procthor_house_given_as_import_path_names_the_importer(tmp_path):
    f = tmp_path / "house.json"
    f.write_text(json.dumps({"rooms": [{"id": "r0", "floorPolygon": []}], "objects": []}))
    with pytest.raises(SceneValidationError, match=r"ProcTHOR house.*interllm scene import-procthor"):
        load_scene_file(f)


@pytest.mark.parametrize("fault, match", [
    ("invalid_json", r"answered http://127\.0\.0\.1:\d+/api/chat \(llm\.host\) with a body that is not Ollama's JSON"),
    ("http_500", r"answered http://127\.0\.0\.1:\d+/api/chat \(llm\.host\) with HTTP 500: 'llama runner process"),
])
def test_ollama_protocol_faults_name_the_url(tmp_path, fault, match):
    with FakeOllama(fault=fault) as srv:
        client = make_client(_ollama_cfg(srv.host, tmp_path))
        with pytest.raises(OllamaProtocolError, match=match):
            client.complete(REQ)


def _cache_client(tmp_path, mode="readwrite"):
    return make_client(LLMConfig(cache_dir=str(tmp_path / "cache"), cache_mode=mode),
                       backend=DeterministicBackend())


def test_bad_cache_entries_are_named_and_recomputed(tmp_path, caplog):
    c = _cache_client(tmp_path)
    first = c.complete(REQ)
    path = c.cache.path_for(first.key)
    path.write_bytes(b'{"key": "\xff\xfe"}')  # not UTF-8
    with caplog.at_level(logging.WARNING):
        again = _cache_client(tmp_path).complete(REQ)
    assert again.text == first.text and not again.cached
    assert str(path) in caplog.text and "corrupt" in caplog.text
    path.unlink()
    path.mkdir()  # an entry replaced by a directory
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        third = _cache_client(tmp_path).complete(REQ)
    assert third.text == first.text and path.is_dir()
    assert "cannot be read" in caplog.text and "cannot be written" in caplog.text


READONLY_SCRIPT = """
import logging, sys
logging.basicConfig(level=logging.WARNING)
from interllm.config import LLMConfig
from interllm.llm import LLMRequest, Message, make_client
from interllm.llm.testing import DeterministicBackend
schema = {"type": "object", "properties": {"a": {"type": "integer"}}, "required": ["a"]}
c = make_client(LLMConfig(cache_dir=sys.argv[1]), backend=DeterministicBackend())
for text in ("Give a.", "Give another a."):  # a hit, then a miss
    r = c.complete(LLMRequest(purpose="candidates", messages=(Message("user", text),), schema=schema))
    print(r.cached, r.text)
"""


def test_a_read_only_cache_degrades_to_no_caching_with_a_warning(tmp_path):
    cache = tmp_path / "cache"
    c = make_client(LLMConfig(cache_dir=str(cache)), backend=DeterministicBackend())
    c.complete(REQ)
    before = {p: p.read_bytes() for p in cache.rglob("*") if p.is_file()}
    dirs = [cache, *(p for p in cache.rglob("*") if p.is_dir())]
    undo = make_read_only(dirs)
    try:
        r = subprocess.run([sys.executable, "-c", READONLY_SCRIPT, str(cache)], cwd=ROOT, capture_output=True,
                           text=True, timeout=120)
    finally:
        undo_read_only(undo)
        for p in dirs:
            p.chmod(0o755)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines()[0].startswith("True") and r.stdout.splitlines()[1].startswith("False")
    assert "cannot be written" in r.stderr and "not cached" in r.stderr
    assert {p: p.read_bytes() for p in cache.rglob("*") if p.is_file()} == before  # nothing lost or changed


# -- quiet failures become loud ------------------------------------------------------------------------
def test_report_on_missing_sweeps_folder_exits_nonzero(tmp_path):
    r = _cli("report", "--sweeps", str(tmp_path / "nope"), "--out", str(tmp_path / "rep"))
    assert r.returncode == 2 and "do not exist" in r.stderr and not (tmp_path / "rep").exists()


def test_replay_of_a_folder_converts_what_it_can_and_lists_the_rest(tmp_path):
    from helpers.recording import rerun_cli, write_run

    if rerun_cli() is None:
        pytest.skip("rerun CLI not installed")
    runs = tmp_path / "runs"
    runs.mkdir()
    write_run(runs / "m000.mcap")
    (runs / "m001.mcap").write_bytes(b"not an mcap file at all")
    write_run(runs / "m002.mcap")
    r = _cli("replay", str(runs))
    assert r.returncode == 1
    assert (runs / "m000.rrd").is_file() and (runs / "m002.rrd").is_file() and not (runs / "m001.rrd").exists()
    assert "1 of 3 run logs could not be replayed" in r.stderr and "m001.mcap" in r.stderr


def test_a_server_that_is_down_stops_the_run_before_any_stage_writes(tmp_path):
    host = f"http://127.0.0.1:{free_port()}"
    r = subprocess.run([sys.executable, "-m", "pipeline.run", "experiment=quick", "llm=ollama", f"llm.host={host}",
                        f"hydra.run.dir={tmp_path / 'run'}"], cwd=ROOT, capture_output=True, text=True, timeout=180)
    assert r.returncode == 2, r.stderr
    assert f"the Ollama server at {host} (llm.host) is not reachable" in r.stderr and "ollama serve" in r.stderr
    assert not (tmp_path / "run" / "data").exists()
