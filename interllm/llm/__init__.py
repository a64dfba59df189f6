"""LLM layer: one cached, logged client over a backend (embedded llama.cpp, Ollama, any
OpenAI-compatible server, or the ground-truth oracle).

    from interllm.llm import make_client, LLMRequest, Message
    client = make_client(cfg.llm, call_log_path="data/runs/llm_calls.jsonl", context={"stage": "candidates"})
    resp = client.with_context(planner="inter_llm", mission="m0").complete(
        LLMRequest(purpose="candidates", messages=(Message("user", "..."),), schema={...},
                   options=client.default_options(sample_index=j, seed=planning_seed(base, "candidates", j))))

Modules: ``types`` (requests and responses), ``backend`` (the Backend protocol and factory),
``client`` (cache + call log + schema repair), ``client_state`` (counters, failure share and model
pin shared by a client's views), ``cache``, ``calllog``, ``schema``, ``health`` (failure share),
``deadline``, ``retry`` (Retry-After and backoff within the deadline), ``redact`` (keys out of
quoted server text), ``entry_layout`` (the cached responses' layouts), ``prompts``, ``errors``;
backends ``embedded`` (with ``model_files``, the GGUF, and ``llama_internals``, the llama-cpp-python
internals it needs and their start-up check),
``ollama_backend``, ``openai_backend`` and ``oracle_backend`` (imported on the first lookup in
``BACKENDS``); ``testing`` holds a deterministic test backend (never imported here). Names are
imported from their modules on first use (``interllm.lazy``), so reading a call log
(``interllm.llm.calllog``) loads no backend.
"""

from interllm.lazy import exports_of, lazy_exports

_EXPORTS = exports_of({
    "interllm.llm.backend": ("BACKENDS", "Backend", "Generation", "Scores", "make_backend", "preflight"),
    "interllm.llm.cache": ("CacheMissError", "ResponseCache", "cache_key"),
    "interllm.llm.calllog": ("CallLog",),
    "interllm.llm.client": ("LLMClient", "make_client"),
    "interllm.llm.client_state": ("ClientStats",),
    "interllm.llm.errors": ("LLMError", "LLMOutputError", "LLMQualityError"),
    "interllm.llm.prompts": ("Template", "TemplateError", "load_template", "template_names"),
    "interllm.llm.schema": ("check_answer",),
    "interllm.llm.types": ("LLMClientProtocol", "LLMOptions", "LLMRequest", "LLMResponse", "Message", "ScoreRequest",
                           "ScoreResponse"),
})
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
