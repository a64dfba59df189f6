"""Shared test helpers (no tests here): tiny scenes and scripted LLM clients (``planners``), run-log
builders (``recording``), local OpenAI-compatible and Ollama servers (``openai_server``,
``ollama_server``) and the embedded model's golden answers (``llm_golden``). Test modules import them
as ``helpers.<module>``: pytest puts ``tests/`` on ``sys.path``."""
