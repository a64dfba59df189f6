"""Record the LLM cache entries a test run reads, in every process (test workers, stage
subprocesses, DVC stages): with this folder first on ``PYTHONPATH`` and ``INTERLLM_CACHE_READS`` set
to a file, every cache hit appends ``{"key": ...}`` to it, the call-log shape ``interllm cache
prune --keep`` reads. Used once after a prune-worthy change to list what the tests replay:

    PYTHONPATH=tests/helpers/cache_reads INTERLLM_CACHE_READS=/tmp/reads.jsonl .venv/bin/python -m pytest -m ""
    sort -u /tmp/reads.jsonl > tests/replayed_llm_calls.jsonl

Without ``INTERLLM_CACHE_READS`` this module does nothing."""

import json
import os

_OUT = os.environ.get("INTERLLM_CACHE_READS")

if _OUT:
    import interllm.llm.cache as _cache  # imports interllm first: the numerics pin stays first

    _get = _cache.ResponseCache.get

    def _recording_get(self, key, *args, **kwargs):
        resp = _get(self, key, *args, **kwargs)
        if resp is not None:
            with open(_OUT, "a", encoding="utf-8") as f:  # one short line per write: appends do not interleave
                f.write(json.dumps({"key": key}) + "\n")
        return resp

    _cache.ResponseCache.get = _recording_get
