"""Record the committed LLM cache entries a test run reads, in every process (test workers, stage
subprocesses, DVC stages): with this folder first on ``PYTHONPATH`` and ``INTERLLM_CACHE_READS`` set
to a file, every cache hit whose key has an entry in this checkout's ``data/llm_cache`` (tests
also read copies of it) appends ``{"key": ...}`` to that file, the call-log shape ``interllm cache
prune --keep`` reads. Used after a prune-worthy change to list what the tests replay:

    PYTHONPATH=$PWD/tests/helpers/cache_reads INTERLLM_CACHE_READS=/tmp/reads.jsonl \\
        .venv/bin/python -m pytest -m ""
    sort -u /tmp/reads.jsonl > tests/replayed_llm_calls.jsonl

The path must be absolute: stage subprocesses run in other folders. Two tests fail in such a run
by design: the stage-imports check (this module imports the cache into every stage) and, when the
list is being made anew, the check that the list exists. Without ``INTERLLM_CACHE_READS`` this
module does nothing."""

import json
import os
from pathlib import Path

_OUT = os.environ.get("INTERLLM_CACHE_READS")
_COMMITTED = Path(__file__).resolve().parents[3] / "data" / "llm_cache"

if _OUT:
    import interllm.llm.cache as _cache  # imports interllm first: the numerics pin stays first

    _get = _cache.ResponseCache.get

    def _recording_get(self, key, *args, **kwargs):
        resp = _get(self, key, *args, **kwargs)
        if resp is not None and (_COMMITTED / key[:2] / f"{key}.json").is_file():
            with open(_OUT, "a", encoding="utf-8") as f:  # one short line per write: appends do not interleave
                f.write(json.dumps({"key": key}) + "\n")
        return resp

    _cache.ResponseCache.get = _recording_get
