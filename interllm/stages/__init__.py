"""The experiment's stages as plain library functions (no hydra, no dvc), one module per stage.

Each reads its inputs from folders, calls the layers below and writes its outputs atomically;
a stage module's imports are the code its DVC stage depends on (``dvc.yaml`` lists them).
``pipeline/*.py`` are the thin DVC entry points; ``stages.pipeline.run_all`` chains all five for
Hydra runs and multiruns.

Layout under ``data_dir``:
  scenes/<scene_id>/{scene.json, grid.npz, scene.xml, missions.json, topdown.png}
  candidates/<scene_id>.json + candidates/llm_calls.jsonl
  runs/<planner>/<scene_id>/<mission_id>.{json,mcap} + runs/llm_calls.jsonl + runs/provenance.json
  metrics/{metrics.json, environment.json, per_object.csv, cumulative.csv, ...}
  report/{report.md, report.html, figures/*.png}
"""
