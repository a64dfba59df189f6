"""LLM layer benchmark (embedded gemma3-270m, CPU).

Prints: prompt-eval and generation tokens/s; the share of prompt tokens served from the KV
prefix cache over one command's M candidates + regenerations (goal >= 70%), with the wall time
against the same calls on a cold context each time; warm-cache replay calls/s (goal >= 1000)
against the backend's calls/s.

    .venv/bin/python benchmarks/bench_llm.py [--m 3] [--regens 2] [--replay-calls 2000]

``--builds`` instead compares the llama.cpp builds in ``.wheels/`` (the pinned baseline of
``make install``, and the native one when ``make install LLAMA_NATIVE=1`` built it): each wheel
is unpacked and measured in a child process of its own (prompt and generation tokens/s, one
thread, best of ``--repeats``, the builds interleaved so machine load hits them alike), and the
ratio native / pinned is the cost of portability.

    .venv/bin/python benchmarks/bench_llm.py --builds [--repeats 5]
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout without install

from interllm import llama_build  # noqa: E402
from interllm.config import LLMConfig  # noqa: E402
from interllm.core.seeding import llm_sample_seed  # noqa: E402
from interllm.llm import LLMRequest, Message, ScoreRequest, make_client  # noqa: E402
from interllm.llm.embedded import EmbeddedBackend  # noqa: E402

SCHEMA = {"type": "object", "properties": {"plan": {"type": "array", "minItems": 1, "maxItems": 3, "items": {
    "type": "object", "properties": {"action": {"enum": ["navigate", "pickup", "place"]},
                                     "target": {"enum": ["cup", "bread", "table_3", "counter_1"]}},
    "required": ["action", "target"]}}}, "required": ["plan"]}


def scene_text(n_rooms: int = 9) -> str:
    rooms = []
    for i in range(n_rooms):
        rooms.append(f"Room {i} (kitchen_{i}) contains table_{i} with cup_{i} and bread_{i}, shelf_{i} with "
                     f"book_{i}, and counter_{i}; door to room {(i + 1) % n_rooms} is open.")
    return "You plan for a mobile manipulator. Scene graph:\n" + "\n".join(rooms)


def command_calls(client, m: int, regens: int, tag: str):
    system = Message("system", scene_text())
    user = Message("user", "Command: bring breakfast to the dining table. Give a plan as JSON.")
    calls = []
    for j in range(m):
        opts = client.default_options(max_tokens=96, sample_index=j, seed=llm_sample_seed(0, tag, j))
        r = client.complete(LLMRequest(purpose="candidates", messages=(system, user), schema=SCHEMA, options=opts))
        calls.append(r)
        msgs = (system, user)
        for k in range(regens):
            msgs = msgs + (Message("assistant", r.text),
                           Message("user", f"Infeasible: step {k + 1} violates a precondition. Fix the plan."))
            r = client.complete(LLMRequest(purpose="regeneration", messages=msgs, schema=SCHEMA, options=opts))
            calls.append(r)
    return calls


def build_speed(n_gen: int = 64) -> dict:
    """Child process: tokens/s of the llama_cpp found first on sys.path (raw API: no project
    check, so a native build can be measured), one thread, greedy decoding."""
    import llama_cpp

    from interllm.llm.model_files import assemble_packaged_model

    llm = llama_cpp.Llama(model_path=str(assemble_packaged_model()), n_ctx=2048, n_threads=1,
                          n_threads_batch=1, verbose=False, seed=0)
    toks = llm.tokenize(scene_text(14).encode(), add_bos=True, special=True)
    t0 = time.perf_counter()
    llm.eval(toks)
    prompt_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    for _ in range(n_gen):
        llm.eval([llm.sample(temp=0.0)])
    gen_s = time.perf_counter() - t0
    info = llama_cpp.llama_print_system_info().decode()
    llm.close()
    return {"system_info": info.strip(), "prompt_tps": len(toks) / prompt_s, "gen_tps": n_gen / gen_s,
            "prompt_tokens": len(toks), "llama_cpp": str(Path(llama_cpp.__file__).parent)}


def compare_builds(repeats: int) -> None:
    """Measure every wheel in .wheels/ in its own child process, interleaved, best of ``repeats``."""
    root = Path(__file__).resolve().parents[1]
    wheels = sorted(root.glob(".wheels/llama-cpp-python-*/llama_cpp_python-*.whl"))
    if not wheels:
        sys.exit("bench_llm --builds: no wheel under .wheels/; run `make install` (and "
                 "`make install LLAMA_NATIVE=1` for the native build) first")
    tmp = Path(tempfile.mkdtemp(prefix="bench_llm_builds_"))
    dirs = {}
    for w in wheels:
        name = w.parent.name.removeprefix("llama-cpp-python-")
        zipfile.ZipFile(w).extractall(tmp / name)
        for lib in (tmp / name).rglob("*.so*"):  # zip drops the mode bits
            lib.chmod(0o755)
        dirs[name] = tmp / name
    best: dict[str, dict] = {}
    for r in range(repeats):
        for name, d in dirs.items():
            env = {**os.environ, "PYTHONPATH": f"{d}{os.pathsep}{root}"}
            out = subprocess.run([sys.executable, __file__, "--child-speed"], env=env, capture_output=True,
                                 text=True, timeout=600)
            if out.returncode != 0:
                print(f"{name}: failed (exit {out.returncode}): {out.stderr.strip()[-300:]}")
                continue
            m = json.loads(out.stdout.strip().splitlines()[-1])
            assert m["llama_cpp"].startswith(str(d)), f"child imported {m['llama_cpp']}, not the wheel {d}"
            b = best.setdefault(name, m)
            b["prompt_tps"], b["gen_tps"] = max(b["prompt_tps"], m["prompt_tps"]), max(b["gen_tps"], m["gen_tps"])
        print(f"repeat {r + 1}/{repeats} done", file=sys.stderr)
    for name, m in best.items():
        print(f"{name}: prompt {m['prompt_tps']:.0f} tokens/s ({m['prompt_tokens']} tokens), "
              f"generation {m['gen_tps']:.1f} tokens/s (best of {repeats}, 1 thread)\n  {m['system_info']}")
    pinned = [m for n, m in best.items() if "-pinned-" in n]
    for name, m in best.items():
        if "-native-" in name and pinned:
            print(f"native / pinned: prompt {m['prompt_tps'] / pinned[0]['prompt_tps']:.2f}x, "
                  f"generation {m['gen_tps'] / pinned[0]['gen_tps']:.2f}x")


def main() -> None:
    if "--child-speed" in sys.argv:
        print(json.dumps(build_speed()))
        return
    ap = argparse.ArgumentParser()
    ap.add_argument("--builds", action="store_true", help="compare the llama.cpp builds in .wheels/")
    ap.add_argument("--repeats", type=int, default=5, help="with --builds: measurements per build")
    ap.add_argument("--m", type=int, default=3)
    ap.add_argument("--regens", type=int, default=2)
    ap.add_argument("--replay-calls", type=int, default=2000)
    ap.add_argument("--threads", type=int, default=1, help="llm.n_threads (2 threads on a loaded 2-core "
                    "machine decode ~100x slower: ggml's thread barriers)")
    a = ap.parse_args()
    if a.builds:
        compare_builds(a.repeats)
        return
    tmp = tempfile.mkdtemp(prefix="bench_llm_")
    cfg = LLMConfig(cache_dir=tmp, n_ctx=4096, n_threads=a.threads)
    be = EmbeddedBackend(cfg)
    t0 = time.perf_counter()
    _ = be.llm
    build = llama_build.describe()
    print(f"model load: {time.perf_counter() - t0:.2f} s; llama.cpp build: {build.get('kind')} "
          f"{build.get('simd_features')}")

    # 1. raw speed: a cold prompt, then generation
    toks = be.tokenize(scene_text(14))
    be.llm.reset()
    be._aligned = 0
    t0 = time.perf_counter()
    be._prefill(toks)
    dt = time.perf_counter() - t0
    print(f"prompt eval: {len(toks)} tokens in {dt:.2f} s = {len(toks) / dt:.0f} tokens/s")

    # 2. one command: M candidates + regenerations, with KV prefix reuse vs cold context each call
    client = make_client(cfg, backend=be)
    t0 = time.perf_counter()
    calls = command_calls(client, a.m, a.regens, "warm")
    warm = time.perf_counter() - t0
    tin = sum(r.tokens_in for r in calls)
    tout = sum(r.tokens_out for r in calls)
    reused = sum(r.prompt_tokens_reused for r in calls)
    gen_s = client.stats.backend_seconds
    print(f"command ({a.m} candidates + {a.regens} regenerations each = {len(calls)} calls): "
          f"prompt tokens {tin}, reused from KV prefix {reused} = {100 * reused / tin:.1f}% (goal >= 70%); "
          f"{tout} tokens out; {warm:.1f} s; {(tin - reused + tout) / gen_s:.0f} evaluated tokens/s")

    class Cold(EmbeddedBackend):
        def _prefill(self, want):
            self._aligned = 0
            return super()._prefill(want)

    cold_be = Cold(cfg)
    cold_be._llm = be.llm
    cold_be._style = be._style
    cold_client = make_client(LLMConfig(cache_dir=tmp, cache_mode="off", n_ctx=4096, n_threads=a.threads), backend=cold_be)
    t0 = time.perf_counter()
    cold_calls = command_calls(cold_client, a.m, a.regens, "warm")
    cold = time.perf_counter() - t0
    same = all(x.text == y.text for x, y in zip(calls, cold_calls, strict=False))
    print(f"  same calls on a cold context: {cold:.1f} s -> prefix reuse speed-up {cold / warm:.2f}x; "
          f"answers identical: {same}")

    # scoring mode: M proposals scored against the same static prompt
    objs = [" cup", " bread", " book", " laptop", " plate", " newspaper"]
    sc = [client.score(ScoreRequest(purpose="proposal", prompt=scene_text() + f"\nCommand {k}: breakfast.\n"
                                    "Useful item:", continuations=tuple(objs), calibration_prompt="Useful item:"))
          for k in range(a.m)]
    s_reused = sum(r.prompt_tokens_reused for r in sc)
    s_in = sum(len(be.tokenize(scene_text() + f"\nCommand {k}: breakfast.\nUseful item:")) for k in range(a.m))
    print(f"scoring {a.m} prompts x {len(objs)} continuations: {sum(r.latency for r in sc):.2f} s, "
          f"prompt tokens reused {s_reused}/{s_in} = {100 * s_reused / s_in:.1f}%")

    # 3. warm-cache replay speed vs the backend
    replay = make_client(LLMConfig(cache_dir=tmp, cache_mode="replay"), backend=be)
    n = a.replay_calls
    t0 = time.perf_counter()
    for i in range(n):
        replay.with_context(mission=str(i)).complete(LLMRequest(
            purpose="candidates", messages=(Message("system", scene_text()),
                                            Message("user", "Command: bring breakfast to the dining table. "
                                                            "Give a plan as JSON.")),
            schema=SCHEMA, options=replay.default_options(max_tokens=96, sample_index=i % a.m,
                                                          seed=llm_sample_seed(0, "warm", i % a.m))))
    dt = time.perf_counter() - t0
    backend_rate = len(calls) / gen_s
    print(f"warm-cache replay: {n} calls in {dt:.2f} s = {n / dt:.0f} calls/s (goal >= 1000); backend "
          f"{backend_rate:.2f} calls/s -> {n / dt / backend_rate:.0f}x")
    be.close()


if __name__ == "__main__":
    main()
