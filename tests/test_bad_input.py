"""Bad input: each case ends in one message naming the problem and the
fix (a config key, file or URL), exit status 2 where a user's input is at fault, and nothing already
written is lost. One group of tests per numbered item of the issue; the OpenAI-compatible cases run
against a fake server on 127.0.0.1 (tests/helpers/openai_server.py)."""

from __future__ import annotations

import concurrent.futures as cf
import errno
import json
import logging
import multiprocessing
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from helpers.openai_server import MODEL, REQ, SCHEMA, FakeOpenAI, openai_cfg  # noqa: E402
from procthor_houses import obj, rect, room_walls  # noqa: E402

from interllm.config import ConfigError, LLMConfig, MissionConfig, from_dict  # noqa: E402
from interllm.errors import StageError  # noqa: E402
from interllm.llm import LLMError, LLMRequest, Message, make_client  # noqa: E402
from interllm.llm.deadline import DeadlineExceeded  # noqa: E402
from interllm.llm.errors import LLMQualityError  # noqa: E402
from interllm.llm.health import check_failure_share  # noqa: E402
from interllm.llm.openai_backend import OpenAIBackend, OpenAIProtocolError  # noqa: E402
from interllm.scene import generate_scene, import_procthor, scene_config, validate_scene  # noqa: E402
from interllm.scene.missions import MissionError, generate_missions  # noqa: E402
from interllm.scene.validate import SceneValidationError  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _run(module: str, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", module, *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, "INTERLLM_PROGRESS": "0"})


def _files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def tiny_scene() -> dict:
    return json.loads(generate_scene(scene_config("tiny", seed=3), 0).to_json())


def _house(objects: list[dict] | None = None, **top) -> dict:
    """A one-room ProcTHOR house (a kitchen [0,4]x[0,3] with a counter), without an ``id``."""
    return {"rooms": [{"id": "room|2", "roomType": "Kitchen", "floorPolygon": rect(0, 0, 4, 3)}],
            "walls": room_walls(2, 0, 0, 4, 3, {"S", "E", "N", "W"}), "doors": [],
            "objects": objects if objects is not None else [obj("CounterTop", 2, 0, 2.0, 0.4)], **top}


# -- 1. a 200 whose body is not JSON, from an OpenAI-compatible server ---------------------------------
@pytest.mark.parametrize("content_type", ["application/json", "text/html"])
@pytest.mark.parametrize("fault, endpoint", [("not_json_models", "/models"),
                                             ("not_json_chat", "/chat/completions")])
def test_1_a_body_that_is_not_json_is_named_by_its_url(tmp_path, fault, endpoint, content_type):
    with FakeOpenAI(fault=fault, content_type=content_type) as srv:
        with pytest.raises(OpenAIProtocolError) as e:
            OpenAIBackend(openai_cfg(srv.base_url, tmp_path)).probe()
    assert f"the server answered {srv.base_url}{endpoint} (llm.base_url) with a body that is not the " \
           f"OpenAI API's JSON" in str(e.value)
    assert "is llm.base_url an OpenAI-compatible endpoint (usually ending in /v1)?" in str(e.value)


def test_1_llm_probe_and_pipeline_run_stop_with_the_message_and_exit_2(tmp_path):
    with FakeOpenAI(fault="not_json_models") as srv:
        probe = _run("interllm.cli", "llm", "probe", "llm.backend=openai", f"llm.model={MODEL}",
                     f"llm.base_url={srv.base_url}", timeout=120)
        run = _run("pipeline.run", "experiment=quick", "llm=openai", f"llm.model={MODEL}",
                   f"llm.base_url={srv.base_url}", f"hydra.run.dir={tmp_path / 'run'}")
    want = (f"the server answered {srv.base_url}/models (llm.base_url) with a body that is not the OpenAI "
            f"API's JSON")
    for r in (probe, run):
        assert r.returncode == 2, r.stderr[-2000:]
        assert want in r.stderr and "Traceback" not in r.stderr
    assert probe.stderr.splitlines()[-1].startswith("interllm: error: the server answered")
    assert run.stderr.splitlines()[-1].startswith("error: the server answered")
    assert not (tmp_path / "run" / "data").exists()  # stopped before any stage wrote


# -- 2. failed answers replayed from the cache ---------------------------------------------------------
def test_2_failures_replayed_from_the_cache_say_so_and_how_to_ask_again(tmp_path):
    reqs = [LLMRequest(purpose="candidates", messages=(Message("user", f"Where is thing {i}?"),),
                       schema=SCHEMA) for i in range(20)]
    with FakeOpenAI(fault="bad_json") as srv:  # the first run: every answer is broken, and cached as failed
        client = make_client(openai_cfg(srv.base_url, tmp_path, repair_retries=0))
        for r in reqs:
            with pytest.raises(LLMError):
                client.complete(r)
        client.close()
    cache = tmp_path / "cache"
    stored = _files(cache)
    calls = tmp_path / "llm_calls.jsonl"
    with FakeOpenAI() as srv:  # the server is fixed; the rerun replays the failures
        client = make_client(openai_cfg(srv.base_url, tmp_path, repair_retries=0), call_log_path=calls)
        for r in reqs[:-1]:
            with pytest.raises(LLMError):
                client.complete(r)
        with pytest.raises(LLMQualityError) as early:  # the mid-stage stop, at the 20th failed call
            client.complete(reqs[-1])
        client.close()
        asked = [b for p, b in srv.requests if p.endswith("/chat/completions") and "thing" in json.dumps(b)]
    with pytest.raises(LLMQualityError) as end:  # the end-of-stage check on the call log
        check_failure_share(calls, openai_cfg("http://127.0.0.1:1/v1", tmp_path), "candidates stage")
    assert not asked  # the server was not asked: the answers came from the cache
    for e in (early, end):
        msg = str(e.value)
        assert "20 of the 20 failed answers came from the LLM cache (llm.cache_dir=" in msg
        assert "the server was not asked again" in msg
        assert "rerun once with llm.cache_mode=retry_failures to ask it again" in msg
    assert "stopping early" in str(early.value) and "candidates stage (call log" in str(end.value)
    assert _files(cache) == stored  # the cache entries are kept as they were


def test_2_without_cached_failures_the_advice_stays_check_the_model(tmp_path):
    with FakeOpenAI(fault="bad_json") as srv:
        calls = tmp_path / "calls.jsonl"
        cfg = openai_cfg(srv.base_url, tmp_path, repair_retries=0, cache_mode="off")
        client = make_client(cfg, call_log_path=calls)
        with pytest.raises(LLMError):
            client.complete(REQ)
        client.close()
    with pytest.raises(LLMQualityError, match=r"\. Check the model and server") as e:
        check_failure_share(calls, openai_cfg("http://127.0.0.1:1/v1", tmp_path), "candidates stage")
    assert "LLM cache" not in str(e.value)


# -- 3. one deadline, whatever timer notices a hang first ----------------------------------------------
def _ollama(timeout_s: float):
    from interllm.llm.ollama_backend import OllamaBackend

    cfg = LLMConfig(backend="ollama", model="m", host="http://127.0.0.1:9", timeout_s=timeout_s,
                    proposal_mode="generate", cost_inference_mode="generate")
    return OllamaBackend(cfg)


def test_3_the_client_libraries_time_out_only_after_the_deadline(tmp_path):
    be = OpenAIBackend(openai_cfg("http://127.0.0.1:9/v1", tmp_path, timeout_s=2.0))
    assert float(be.client.timeout) > 2.0  # the library's own timeout cannot beat llm.timeout_s
    assert _ollama(2.0).client._client.timeout.read > 2.0


def test_3_a_client_library_timeout_reads_as_the_deadline(tmp_path):
    import httpx
    import httpx2
    import openai

    def openai_timeout(client):
        raise openai.APITimeoutError(request=httpx2.Request("POST", "http://127.0.0.1:9/v1/chat/completions"))

    def ollama_timeout(client):
        raise httpx.ReadTimeout("timed out")

    deadline = ("did not answer within llm.timeout_s=2 s (a whole-call deadline); the server is stuck or too "
                "slow: check it, or raise llm.timeout_s")
    with pytest.raises(DeadlineExceeded) as e:
        OpenAIBackend(openai_cfg("http://127.0.0.1:9/v1", tmp_path, timeout_s=2.0))._call("/chat/completions",
                                                                                  openai_timeout)
    assert str(e.value) == ("the OpenAI-compatible call to http://127.0.0.1:9/v1/chat/completions "
                            f"(llm.base_url) {deadline}")
    with pytest.raises(DeadlineExceeded) as e:
        _ollama(2.0)._call("/api/chat", ollama_timeout)
    assert str(e.value) == f"the Ollama call to http://127.0.0.1:9/api/chat (llm.host) {deadline}"


def test_3_a_hang_reads_as_a_hang_every_time(tmp_path):
    with FakeOpenAI(fault="hang", hang_s=15) as srv:
        client = make_client(openai_cfg(srv.base_url, tmp_path, timeout_s=2.0))
        for _ in range(3):
            t0 = time.monotonic()
            with pytest.raises(DeadlineExceeded, match=r"did not answer within llm\.timeout_s=2 s"):
                client.complete(REQ)
            assert time.monotonic() - t0 < 6
    assert not (tmp_path / "cache").exists() or not list((tmp_path / "cache").rglob("*.json"))


# -- 4. tracebacks that become one message -------------------------------------------------------------
def test_4_a_nan_coordinate_is_named_in_scene_validate_and_in_the_scenes_stage(tmp_path, tiny_scene):
    d = json.loads(json.dumps(tiny_scene))
    d["rooms"][0]["polygon"][1][0] = float("nan")
    f = tmp_path / "nan_scene.json"
    f.write_text(json.dumps(d))  # Python writes NaN, and reads it back
    before = f.read_bytes()
    r = _run("interllm.cli", "scene", "validate", str(f), timeout=120)
    want = f"{f}: $.rooms[0].polygon[1][0]: nan is not a number a scene can use; write a finite number"
    assert r.returncode == 1 and want in r.stderr and "Traceback" not in r.stderr
    data = tmp_path / "data"
    (data / "scenes").mkdir(parents=True)
    (data / "scenes" / "earlier.txt").write_text("kept\n")
    (tmp_path / "params.yaml").write_text(json.dumps({"data_dir": str(data), "scene": {"import_path": str(f)},
                                                      "llm": {"backend": "oracle", "proposal_mode": "oracle",
                                                              "cost_inference_mode": "oracle"}}))
    r = _run("pipeline.scenes", "--params", str(tmp_path / "params.yaml"), timeout=120)
    assert r.returncode == 2 and f"error: stage 'scenes': {want}" in r.stderr and "Traceback" not in r.stderr
    assert f.read_bytes() == before and (data / "scenes" / "earlier.txt").read_text() == "kept\n"


def test_4_import_procthor_out_pointing_at_a_file_keeps_the_file(tmp_path):
    house, out = tmp_path / "house.json", tmp_path / "notes.txt"
    house.write_text(json.dumps(_house()))
    out.write_text("my notes\n")
    r = _run("interllm.cli", "scene", "import-procthor", str(house), "--out", str(out), timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert f"interllm: error: --out {out} is an existing file, not a folder; name a folder" in r.stderr
    assert out.read_text() == "my notes\n"


def test_4_an_empty_model_name_is_a_config_error(tmp_path):
    r = _run("pipeline.run", "experiment=quick", "llm=openai", "llm.model=",
             "llm.base_url=http://127.0.0.1:9/v1", f"hydra.run.dir={tmp_path / 'run'}")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "error: config key 'llm.model': the openai backend needs a model name, e.g. " \
           "llm.model=gpt-4o" in r.stderr
    assert not (tmp_path / "run" / "data").exists()


@pytest.mark.parametrize("code, strerror, wrapped, what, fix", [
    (errno.EROFS, "Read-only file system", False, "cannot write", "; run in a writable copy of the project"),
    (errno.EACCES, "Permission denied", False, "no access to", "; give this user write access to it"),
    (errno.ENOSPC, "No space left on device", True, "cannot write", "(the disk is full); free some space"),
])
def test_4_a_read_only_or_full_disk_in_a_stage_is_one_message(tmp_path, monkeypatch, capsys, code, strerror,
                                                              wrapped, what, fix):
    import pipeline._common as common

    monkeypatch.delenv("DVC_STAGE", raising=False)
    (tmp_path / "params.yaml").write_text(f"data_dir: {tmp_path / 'data'}\n")
    blocked = tmp_path / "data" / "scenes" / "s1" / "scene.json"

    def body(cfg, raw, data):
        (data / "scenes" / "s0").mkdir(parents=True)
        (data / "scenes" / "s0" / "scene.json").write_text("{}\n")  # written before the disk filled up
        err = OSError(code, strerror, str(blocked))
        if not wrapped:
            raise err
        raise RuntimeError("writing the run log failed") from err

    monkeypatch.setattr(sys, "argv", ["pipeline.scenes", "--params", str(tmp_path / "params.yaml")])
    with pytest.raises(SystemExit) as e:
        common.stage_main("scenes", body)
    err = capsys.readouterr().err
    assert e.value.code == 2 and "Traceback" not in err
    assert f"error: stage 'scenes': {what} {blocked}: {strerror}" in err and fix in err
    assert "the files written before are kept" in err
    assert (tmp_path / "data" / "scenes" / "s0" / "scene.json").read_text() == "{}\n"


def test_4_a_read_only_data_folder_stops_the_scenes_stage_with_one_message(tmp_path):
    from helpers.files import make_read_only, undo_read_only

    scenes = tmp_path / "data" / "scenes"
    scenes.mkdir(parents=True)
    (scenes / "earlier.txt").write_text("kept\n")
    (tmp_path / "params.yaml").write_text(json.dumps({
        "data_dir": str(tmp_path / "data"), "scene": {"name": "tiny", "n_scenes": 1},
        "llm": {"backend": "oracle", "proposal_mode": "oracle", "cost_inference_mode": "oracle"}}))
    undo = make_read_only([scenes])
    try:
        r = _run("pipeline.scenes", "--params", str(tmp_path / "params.yaml"), timeout=300)
    finally:
        undo_read_only(undo)
        scenes.chmod(0o755)
    assert r.returncode == 2 and "Traceback" not in r.stderr and "unexpected error" not in r.stderr
    assert r.stderr.startswith("error: stage 'scenes': ") and f" {scenes}/" in r.stderr
    assert "run in a writable copy of the project; the files written before are kept" in r.stderr
    assert _files(scenes) == {"earlier.txt": b"kept\n"}


def test_4_a_full_disk_in_a_mission_worker_is_a_stage_error(tmp_path, monkeypatch):
    from interllm.stages import missions

    class FullDisk:
        out_dir = tmp_path

        def run(self, planner, sid, mid):
            path = tmp_path / planner / sid / f"{mid}.mcap"
            raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(missions, "_WORKER", FullDisk())
    with pytest.raises(StageError) as e:
        missions._run_in_worker(("inter_llm", "s0", "m000"))
    assert "planner 'inter_llm' on scene 's0' mission 'm000' failed: OutputError: cannot write" \
        in str(e.value)
    assert "No space left on device (the disk is full)" in str(e.value) and "Traceback" not in str(e.value)


def test_4_a_dead_mission_worker_is_a_stage_error(tmp_path):
    from interllm.stages.missions import wait_for_jobs

    ctx = multiprocessing.get_context("spawn")
    with cf.ProcessPoolExecutor(1, mp_context=ctx) as pool:
        futures = {pool.submit(os._exit, 9): ("inter_llm", "s0", "m000")}  # the worker dies mid-job
        with pytest.raises(StageError) as e:
            wait_for_jobs(futures, 1)
    assert "missions stage: a worker process died (killed, out of memory?)" in str(e.value)
    assert "rerun with jobs=1" in str(e.value) and "the finished runs are kept" in str(e.value)


# -- 5. advice that fits the case ----------------------------------------------------------------------
def _lock(root: Path, md5: str) -> None:
    (root / "dvc.lock").write_text(json.dumps({"schema": "2.0", "stages": {"scenes": {
        "cmd": "sh pipeline/stage scenes", "outs": [{"path": "data/scenes", "hash": "md5", "md5": md5}]}}}))


def test_5_dvc_note_only_when_the_cache_holds_the_outputs(tmp_path, monkeypatch, capsys):
    import pipeline._common as common

    md5 = "c7fb7d6d78aa97b921caa215c5bb00f3.dir"
    _lock(tmp_path, md5)
    (tmp_path / "params.yaml").write_text("planner:\n  M: abc\n")
    monkeypatch.setattr(common, "ROOT", tmp_path)
    monkeypatch.setenv("DVC_STAGE", "scenes")
    monkeypatch.setattr(sys, "argv", ["pipeline.scenes", "--params", str(tmp_path / "params.yaml")])

    def failed_stage() -> str:
        with pytest.raises(SystemExit) as e:
            common.stage_main("scenes", lambda cfg, raw, data: None)
        assert e.value.code == 2
        return capsys.readouterr().err

    fresh = failed_stage()  # a fresh clone: dvc.lock names outputs, the DVC cache has none
    assert "config key 'planner.M'" in fresh and "dvc checkout" not in fresh
    cached = tmp_path / ".dvc" / "cache" / "files" / "md5" / md5[:2] / md5[2:]
    cached.parent.mkdir(parents=True)
    cached.write_text("[]")
    restorable = failed_stage()
    assert "config key 'planner.M'" in restorable
    assert "`dvc checkout scenes` restores them from the DVC cache" in restorable


def test_5_dvc_cache_dir_from_the_config(tmp_path):
    from pipeline._common import cached_outputs

    md5 = "0123456789abcdef0123456789abcdef.dir"
    _lock(tmp_path, md5)
    (tmp_path / ".dvc").mkdir()
    (tmp_path / ".dvc" / "config.local").write_text(f"[cache]\n    dir = {tmp_path / 'shared'}\n")
    assert not cached_outputs(tmp_path, "scenes") and not cached_outputs(tmp_path, "missions")
    (tmp_path / "shared" / "files" / "md5" / md5[:2]).mkdir(parents=True)
    (tmp_path / "shared" / "files" / "md5" / md5[:2] / md5[2:]).write_text("[]")
    assert cached_outputs(tmp_path, "scenes")


def test_5_llm_probe_overrides_start_from_the_backend_they_name(tmp_path):
    params = tmp_path / "params.yaml"  # as `dvc exp run -S llm=oracle` leaves it
    params.write_text("llm:\n  backend: oracle\n  proposal_mode: oracle\n  cost_inference_mode: oracle\n"
                      "  oracle_error: 0.25\n")
    before = params.read_bytes()
    with FakeOpenAI() as srv:
        r = _run("interllm.cli", "llm", "probe", "--params", str(params), "llm.backend=openai",
                 f"llm.model={MODEL}", f"llm.base_url={srv.base_url}", timeout=120)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["json_schema"] == "json_schema"
    assert "note: llm.backend=openai: the llm section is the openai preset (conf/llm/openai.yaml) with the " \
           "other overrides on top, not params.yaml's llm section (llm.backend='oracle')" in r.stderr
    assert params.read_bytes() == before


def test_5_no_generate_a_larger_scene_for_an_imported_scene(tiny_scene):
    house = import_procthor(_house())
    with pytest.raises(MissionError) as e:
        generate_missions(house, MissionConfig(objects_per_command=6), 0.25)
    assert "generate a larger scene" not in str(e.value)
    assert "add objects the commands use to the scene file (scene.import_path), or lower " \
           "mission.objects_per_command" in str(e.value)
    generated = generate_scene(scene_config("tiny", seed=3), 0)
    generated.objects.clear()
    with pytest.raises(MissionError, match="generate a larger scene"):
        generate_missions(generated, MissionConfig(objects_per_command=6), 0.25)


# -- 6. the smaller items ------------------------------------------------------------------------------
def _flip_inside_a_chunk(path: Path) -> int:
    """Flip one bit in the middle of the first chunk of an MCAP file; returns its offset."""
    import io

    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    data = bytearray(path.read_bytes())
    bio = io.BytesIO(bytes(data))
    for rec in StreamReader(bio, emit_chunks=True).records:
        if isinstance(rec, Chunk):
            at = bio.tell() - len(rec.data) // 2
            data[at] ^= 0x10
            path.write_bytes(bytes(data))
            return at
    raise AssertionError("no chunk")


def test_6_a_bit_flipped_mcap_is_damaged_not_truncated(tmp_path):
    from helpers.recording import write_run

    from interllm.record import read_run
    from interllm.record.reader import RunLogCorruptError

    path = tmp_path / "m000.mcap"
    write_run(path, 6, 40, chunk_size=2048)
    _flip_inside_a_chunk(path)
    damaged = path.read_bytes()
    with pytest.raises(RunLogCorruptError, match=r"m000\.mcap is damaged at byte \d+ of \d+ .*not a killed "
                                                 r"run's truncation.*`dvc checkout missions`"):
        read_run(path)
    cut = tmp_path / "cut.mcap.partial"  # a killed run's file is still read up to where it stops
    cut.write_bytes(damaged[:len(damaged) // 3])
    assert not read_run(cut).complete
    p = subprocess.run([sys.executable, "-c", "import sys; from interllm.record import replay_main; "
                        f"sys.exit(replay_main([{str(path)!r}, '--save', {str(tmp_path / 'x.rrd')!r}]))"],
                       capture_output=True, text=True, timeout=120, env={**os.environ, "CI": "1"})
    assert p.returncode == 2 and "is damaged at byte" in p.stderr and "truncated" not in p.stdout
    assert path.read_bytes() == damaged  # left as it is


def test_6_import_procthor_says_what_it_was_given(tmp_path, tiny_scene):
    house = tmp_path / "house.json"
    house.write_text(json.dumps(_house(metadata={"schema": "2.0.0"})))
    r = _run("interllm.cli", "scene", "import-procthor", str(house), "--out", str(tmp_path / "out"),
             timeout=120)
    assert r.returncode == 0, r.stderr
    line = "1 × schema '2.0.0': not the ProcTHOR schema 1.0.0 this importer knows; converted as 1.0.0"
    assert line in r.stdout and line in (tmp_path / "out" / "import_report.txt").read_text()
    ours = tmp_path / "ours.json"
    ours.write_text(json.dumps(tiny_scene))
    r = _run("interllm.cli", "scene", "import-procthor", str(ours), "--out", str(tmp_path / "out2"),
             timeout=120)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert f"{ours}: $: this is already a scene in interllm's format, not a ProcTHOR house: use it as it " \
           f"is, scene.import_path={ours}" in r.stderr
    assert not (tmp_path / "out2").exists() and json.loads(ours.read_text()) == tiny_scene


def test_6_oracle_error_with_a_model_backend_is_refused():
    with pytest.raises(ConfigError) as e:
        from_dict({"llm": {"backend": "openai", "model": "gpt-4o", "proposal_mode": "generate",
                           "cost_inference_mode": "generate", "oracle_error": 0.2}})
    assert "config key 'llm.oracle_error': 0.2 is the error rate of the oracle (llm=oracle), but " \
           "llm.backend='openai' asks a model" in str(e.value)
    assert "drop llm.oracle_error, or use llm=oracle llm.oracle_error=0.2" in str(e.value)
    from_dict({"llm": {"backend": "oracle", "proposal_mode": "oracle", "cost_inference_mode": "oracle",
                       "oracle_error": 0.2}})


def test_6_furniture_outside_every_room_is_named_as_such(tiny_scene):
    d = json.loads(json.dumps(tiny_scene))
    f = d["furniture"][0]
    xs = [p[0] for r in d["rooms"] for p in r["polygon"]]
    dx = max(xs) - f["center"][0] + 5.0  # 5 m east of the house
    f["center"][0] += dx
    for o in d["objects"]:
        if o["furniture"] == f["id"]:
            o["position"][0] += dx
    with pytest.raises(SceneValidationError) as e:
        validate_scene(d, source="moved.json")
    assert f"moved.json: $.furniture[0].center: furniture {f['id']!r} at {tuple(f['center'])} lies outside " \
           f"every room; move it inside its room {f['room']!r}" in str(e.value)
    assert "also unreachable: []" not in str(e.value)


def test_6_an_imported_house_without_an_id_is_named_after_its_file(tmp_path):
    f = tmp_path / "my house (2).json"
    f.write_text(json.dumps(_house()))
    assert import_procthor(f).id == "my_house_2_"
    assert import_procthor(_house()).id == "procthor_house"  # a dict has no file name
    g = tmp_path / "named.json"
    g.write_text(json.dumps(_house(id="kitchen_only")))
    assert import_procthor(g).id == "kitchen_only"


def test_6_http_requests_are_not_logged_on_stdout(tmp_path, capsys):
    from pipeline._common import QUIET_LOGGERS, setup_logging

    root = logging.getLogger()
    saved = (root.level, [(n, logging.getLogger(n).level) for n in QUIET_LOGGERS])
    handler = logging.StreamHandler(sys.stdout)  # as Hydra's job logging sets it up: INFO on stdout
    root.addHandler(handler)
    root.setLevel(logging.INFO)
    try:
        setup_logging(False)
        with FakeOpenAI() as srv:
            OpenAIBackend(openai_cfg(srv.base_url, tmp_path)).probe()
    finally:
        root.removeHandler(handler)
        root.setLevel(saved[0])
        for n, level in saved[1]:
            logging.getLogger(n).setLevel(level)
    assert "HTTP Request" not in capsys.readouterr().out
