"""`interllm` command line: replay runs, scene tools, cache tools.

    interllm replay RUN.mcap [--save OUT.rrd] [--spawn | --serve]
    interllm replay data/runs/inter_llm/scene_000        # a mission set
    interllm scene schema                                # the scene JSON Schema
    interllm scene generate --size paper --seed 0 --out my_scene/
    interllm scene validate my_house.json
    interllm scene import-procthor house.json --out my_scene/
    interllm report --sweeps multirun/                   # report + ablation tables of multiruns
    interllm cache stats [--dir data/llm_cache]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def _scene_generate(args) -> int:
    from interllm.scene import generate_scene, render_topdown
    from interllm.scene.catalog import CatalogError, scene_config

    try:
        cfg = scene_config(args.size, seed=args.seed)
    except CatalogError as e:
        print(f"error: --size: {e}", file=sys.stderr)
        return 2
    scene = generate_scene(cfg, 0)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    from interllm.io import atomic_write_text

    atomic_write_text(out / "scene.json", scene.to_json())
    render_topdown(scene, out / "topdown.png")
    print(f"wrote {out / 'scene.json'} and {out / 'topdown.png'}: {len(scene.rooms)} rooms, "
          f"{len(scene.furniture)} furniture, {len(scene.objects)} objects")
    return 0


def _scene_validate(args) -> int:
    from interllm.scene import load_scene_file
    from interllm.scene.validate import SceneValidationError

    try:
        scene = load_scene_file(args.file)
    except SceneValidationError as e:
        print(f"invalid: {e}", file=sys.stderr)
        return 1
    print(f"ok: {args.file}: {len(scene.rooms)} rooms, {len(scene.furniture)} furniture, "
          f"{len(scene.objects)} objects")
    return 0


def _scene_import(args) -> int:
    from interllm.io import atomic_write_text
    from interllm.scene.importer import import_procthor
    from interllm.scene.validate import SceneValidationError, validate_scene

    try:
        scene = import_procthor(args.file)
        validate_scene(scene, source=str(args.file))
    except SceneValidationError as e:
        print(f"invalid: {e}", file=sys.stderr)
        return 1
    out = Path(args.out)
    atomic_write_text(out / "scene.json", scene.to_json())
    print(f"wrote {out / 'scene.json'}; use it with scene.import_path={out / 'scene.json'}")
    return 0


def _report(args) -> int:
    import yaml

    from interllm.config import from_dict
    from interllm.experiment import find_sweep_results, run_report

    data = Path(args.data)
    params = Path(args.params)
    cfg = from_dict(yaml.safe_load(params.read_text()) or {}) if params.is_file() else None
    temps, ms = find_sweep_results(*[Path(s) for s in args.sweeps])
    run_report(cfg, data / "metrics", data / "scenes", data / "runs", Path(args.out),
               temperature_results=temps, m_results=ms)
    print(f"wrote {args.out}/report.html with {len(temps)} temperature and {len(ms)} M ablation results")
    return 0


def _cache_stats(args) -> int:
    d = Path(args.dir)
    files = list(d.rglob("*.json")) if d.is_dir() else []
    size = sum(f.stat().st_size for f in files)
    print(f"{d}: {len(files)} entries, {size / 1e6:.2f} MB")
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "replay":
        from interllm.record.replay import replay_main

        return replay_main(argv[1:])
    ap = argparse.ArgumentParser(prog="interllm", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("replay", help="replay an MCAP run (or a folder of runs) in rerun")
    sc = sub.add_parser("scene", help="scene tools").add_subparsers(dest="scmd", required=True)
    sc.add_parser("schema", help="print the scene JSON Schema")
    g = sc.add_parser("generate", help="generate a house")
    g.add_argument("--size", default="paper")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--out", required=True)
    v = sc.add_parser("validate", help="validate a scene JSON file")
    v.add_argument("file")
    im = sc.add_parser("import-procthor", help="convert a ProcTHOR house JSON")
    im.add_argument("file")
    im.add_argument("--out", required=True)
    rp = sub.add_parser("report", help="the report, with the ablation results of Hydra multiruns")
    rp.add_argument("--data", default="data", help="folder with metrics/, scenes/, runs/")
    rp.add_argument("--params", default="params.yaml")
    rp.add_argument("--sweeps", nargs="*", default=["multirun"], help="Hydra multirun folders to gather")
    rp.add_argument("--out", default="data/report_ablations")
    ca = sub.add_parser("cache", help="LLM response cache tools").add_subparsers(dest="ccmd", required=True)
    st = ca.add_parser("stats")
    st.add_argument("--dir", default="data/llm_cache")
    args = ap.parse_args(argv)
    if args.cmd == "scene":
        if args.scmd == "schema":
            from interllm.scene.schema import scene_json_schema

            print(json.dumps(scene_json_schema(), indent=2))
            return 0
        return {"generate": _scene_generate, "validate": _scene_validate,
                "import-procthor": _scene_import}[args.scmd](args)
    if args.cmd == "cache":
        return _cache_stats(args)
    if args.cmd == "report":
        return _report(args)
    return 2


if __name__ == "__main__":
    sys.exit(main())
