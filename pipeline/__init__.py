"""Thin DVC stage entry points: load config, read inputs, call one library function, write outputs.

Under DVC, a stage dies with the ``dvc`` process that started it: armed here, before the stage
module's imports, and noticed even when dvc died while the interpreter was starting."""

from interllm.lifetime import die_with_stage_runner

die_with_stage_runner()
