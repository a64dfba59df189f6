"""The report built from the metrics: ``build.build_report`` writes ``report.md``, a
self-contained ``report.html`` and ``figures/*.png`` (matplotlib, ``plots``), one module per part of
the report (``build``'s doc). It depends on ``interllm.metrics`` and never the other way
(``tests/test_layering.py``); the report stage (``interllm.stages.report``) calls it."""
