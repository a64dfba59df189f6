"""High-level planning: the feasibility checker (``feasibility``), grid search (``search``), path
similarity (``similarity``), known costs (``memory``), cost estimation (``costs``), and how the LLM
proposes plans and cost labels (``proposers``, one implementation per mode over ``generation``
and ``scoring``; ``oracle``: the ground-truth input source; ``text`` and ``plans`` hold the prompts'
views and the plan format)."""
