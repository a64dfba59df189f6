"""`interllm` command line: replay runs, scene tools, cache tools.

    interllm replay RUN.mcap [--save OUT.rrd] [--spawn | --serve]
    interllm replay data/runs/inter_llm/scene_000        # a mission set
    interllm scene schema                                # the scene JSON Schema
    interllm scene generate --size paper --seed 0 --out my_scene/
    interllm scene validate my_house.json
    interllm scene import-procthor house.json --out my_scene/ [--strict]
    interllm scene reach my_scene/scene.json [sim/robot=stretch ...] [--json OUT]   # what the robot can pick up
    interllm report --sweeps multirun/                   # report + ablation tables of multiruns
    interllm cache stats [--dir data/llm_cache]
    interllm cache prune --keep 'data/**/llm_calls.jsonl' [--delete]   # drop entries no run used
    interllm results diff [--reference HEAD] [--check]   # metrics.json against the committed one
    interllm llm probe [llm.backend=openai llm.base_url=... llm.model=...]   # what the LLM server does
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def _scene_generate(args) -> int:
    from interllm.config import ConfigError  # lazy: a command loads only its own code
    from interllm.scene import generate_scene, render_topdown  # lazy: a command loads only its own code
    from interllm.scene.catalog import CatalogError, scene_config  # lazy: a command loads only its own code

    try:
        cfg = scene_config(args.size, seed=args.seed, assets=args.assets)
    except (CatalogError, ConfigError) as e:
        print(f"error: {'--assets' if 'scene.assets' in str(e) else '--size'}: {e}", file=sys.stderr)
        return 2
    out = _out_folder(args.out)
    scene = generate_scene(cfg, 0)
    out.mkdir(parents=True, exist_ok=True)
    from interllm.io import atomic_write_text  # lazy: a command loads only its own code

    atomic_write_text(out / "scene.json", scene.to_json())
    render_topdown(scene, out / "topdown.png")
    print(f"wrote {out / 'scene.json'} and {out / 'topdown.png'}: {len(scene.rooms)} rooms, "
          f"{len(scene.furniture)} furniture, {len(scene.objects)} objects")
    return 0


def _scene_validate(args) -> int:
    from interllm.config import SimConfig  # lazy: a command loads only its own code
    from interllm.scene import load_scene_file  # lazy: a command loads only its own code
    from interllm.scene.validate import SceneValidationError  # lazy: a command loads only its own code

    try:
        scene = load_scene_file(args.file, robot_radius=SimConfig().robot_radius)
    except SceneValidationError as e:
        print(f"invalid: {e}", file=sys.stderr)
        return 1
    print(f"ok: {args.file}: {len(scene.rooms)} rooms, {len(scene.furniture)} furniture, "
          f"{len(scene.objects)} objects")
    return 0


def _scene_import(args) -> int:
    from interllm.config import ConfigError, from_dict  # lazy: a command loads only its own code
    from interllm.io import atomic_write_text  # lazy: a command loads only its own code
    from interllm.overrides import compose_config  # lazy: a command loads only its own code
    from interllm.scene.grid import rasterize  # lazy: a command loads only its own code
    from interllm.scene.importer import (  # lazy: a command loads only its own code
        ImportOptions,
        ImportReport,
        import_procthor,
    )
    from interllm.scene.render import render_topdown  # lazy: a command loads only its own code
    from interllm.scene.validate import (  # lazy: a command loads only its own code
        SceneValidationError,
        validate_scene,
    )
    from interllm.sim.reach_report import (  # lazy: a command loads only its own code
        reach_report,
        report_lines,
    )

    out = _out_folder(args.out)
    report = ImportReport()
    try:
        cfg = from_dict(compose_config(args.overrides), source="conf/ and the command line")
    except ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    sim, res = cfg.sim, cfg.scene.grid_resolution  # reachability is judged for the configured robot
    try:
        scene = import_procthor(args.file, report=report, opts=ImportOptions(
            strict=args.strict, robot_radius=sim.robot_radius, resolution=res))
        validate_scene(scene, source=str(args.file), robot_radius=sim.robot_radius, resolution=res)
    except SceneValidationError as e:
        print(f"invalid: {e}", file=sys.stderr)
        return 1
    atomic_write_text(out / "scene.json", scene.to_json())
    reach = report_lines(reach_report(scene, sim, res), sim.robot)
    lines = reach + (report.lines() or ["nothing defaulted, dropped or moved"])
    atomic_write_text(out / "import_report.txt", "\n".join(lines) + "\n")
    render_topdown(scene, out / "topdown.png", grid=rasterize(scene, res, sim.robot_radius, doors="presumed"))
    print("\n".join(["import report:"] + [f"  {ln}" for ln in lines]))
    print(f"wrote {out / 'scene.json'}, {out / 'import_report.txt'} and {out / 'topdown.png'}; use it with "
          f"scene.import_path={out / 'scene.json'}")
    return 0


def _scene_reach(args) -> int:
    from interllm.config import ConfigError, from_dict  # lazy: a command loads only its own code
    from interllm.io import atomic_write_text  # lazy: a command loads only its own code
    from interllm.overrides import compose_config  # lazy: a command loads only its own code
    from interllm.scene import load_scene_file  # lazy: a command loads only its own code
    from interllm.scene.validate import SceneValidationError  # lazy: a command loads only its own code
    from interllm.sim.reach_report import reach_report, report_json, report_lines  # lazy: own code only

    try:
        cfg = from_dict(compose_config(args.overrides), source="conf/ and the command line")
        scene = load_scene_file(args.file, robot_radius=cfg.sim.robot_radius, check_reachability=False)
    except (ConfigError, SceneValidationError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    rows = reach_report(scene, cfg.sim, cfg.scene.grid_resolution)
    print("\n".join(report_lines(rows, cfg.sim.robot)))
    if args.json:
        atomic_write_text(Path(args.json), json.dumps(report_json(rows, cfg.sim.robot), indent=1) + "\n")
    return 0


def _report(args) -> int:
    import yaml  # lazy: a command loads only its own code

    from interllm.config import from_dict  # lazy: a command loads only its own code
    from interllm.stages.report import (  # lazy: a command loads only its own code
        find_encoding_results,
        find_estimate_results,
        find_oracle_results,
        find_sweep_results,
        run_report,
    )

    data = Path(args.data)
    params = Path(args.params)
    missing = [s for s in args.sweeps if not Path(s).is_dir()]
    if missing:
        print(f"interllm report: error: --sweeps folder(s) {missing} do not exist; run the multiruns first "
              f"(docs/configuration.md) or pass the folders they wrote", file=sys.stderr)
        return 2
    if not (data / "metrics" / "metrics.json").is_file():
        print(f"interllm report: error: {data / 'metrics' / 'metrics.json'} is missing; run `make repro` "
              f"(or pass --data)", file=sys.stderr)
        return 2
    cfg = from_dict(yaml.safe_load(params.read_text()) or {}, source=str(params)) if params.is_file() else None
    temps, ms = find_sweep_results(*[Path(s) for s in args.sweeps])
    ests = find_estimate_results(*[Path(s) for s in args.sweeps])
    oracles = find_oracle_results(*[Path(s) for s in args.sweeps])
    encs = find_encoding_results(*[Path(s) for s in args.sweeps])
    if args.sweeps and not temps and not ms and not ests and not oracles and not encs:
        print(f"interllm report: error: no temperature_ablation, m_ablation, estimate_comparison, oracle_sweep or "
              f"encoding_comparison job with data/metrics/metrics.json under {args.sweeps}", file=sys.stderr)
        return 2
    run_report(cfg, data / "metrics", data / "scenes", data / "runs", Path(args.out),
               temperature_results=temps, m_results=ms, estimate_results=ests, oracle_results=oracles,
               encoding_results=encs)
    print(f"wrote {args.out}/report.html with {len(temps)} temperature, {len(ms)} M ablation, {len(ests)} "
          f"estimate-variant, {len(oracles)} oracle and {len(encs)} encoding-variant results")
    return 0


def _cache_stats(args) -> int:
    d = Path(args.dir)
    files = list(d.rglob("*.json")) if d.is_dir() else []
    size = sum(f.stat().st_size for f in files)
    print(f"{d}: {len(files)} entries, {size / 1e6:.2f} MB")
    return 0


def _cache_prune(args) -> int:
    """List (or with --delete remove) the entries no call log under the --keep globs names."""
    from interllm.llm.cache import keys_in_call_logs, stale_entries  # lazy: a command loads only its own code

    logs = sorted({p for g in args.keep for p in Path(".").glob(g)})
    if not logs:
        print(f"interllm cache prune: error: no call log matches --keep {args.keep}; nothing would be kept, "
              f"so nothing is removed", file=sys.stderr)
        return 2
    keep = keys_in_call_logs(logs)
    stale = stale_entries(args.dir, keep)
    for p in stale:
        if args.delete:
            p.unlink()
    verb = "removed" if args.delete else "would remove (pass --delete)"
    print(f"{args.dir}: {len(keep)} keys named by {len(logs)} call logs; {verb} {len(stale)} other entries")
    return 0


def _results_diff(args) -> int:
    """Compare each metrics.json of ``--file`` (and the environment it was made in) with a git
    revision's; the exit status is the worst of the files' (0 same, new or not checked, 1 differ
    with ``--check``, 2 cannot compare: missing or malformed)."""
    return max(_results_diff_one(args, f) for f in args.file)


def _results_diff_one(args, file: str) -> int:
    """``_results_diff`` of one file."""
    from interllm.metrics.compare import (  # lazy: a command loads only its own code
        MetricsShapeError,
        check_metrics_shape,
        committed_file,
        compare_metrics,
    )
    from interllm.numerics import describe_environment_change  # lazy: a command loads only its own code

    root = Path(args.repo).resolve()
    rel = Path(file)
    path = rel if rel.is_absolute() else root / rel
    if not path.is_file():  # first: a mistyped name or a glob that matched nothing is not "new"
        print(f"results diff: {path} is missing: run `make repro` (or `make sweeps`) first, or check the "
              f"--file name", file=sys.stderr)
        return 2
    ref = committed_file(root, rel.as_posix(), args.reference)
    if ref is None:  # a result made for the first time: nothing to compare, nothing wrong
        print(f"{rel.as_posix()} is new: no version at git revision {args.reference} in {root} to compare with.")
        return 0
    try:
        reference = check_metrics_shape(json.loads(ref), f"{rel.as_posix()} at git revision {args.reference}")
        cmp = compare_metrics(reference, check_metrics_shape(json.loads(path.read_text(encoding="utf-8")), str(path)))
    except MetricsShapeError as e:
        print(f"results diff: {e}", file=sys.stderr)
        return 2
    except ValueError as e:
        print(f"results diff: {path} or its {args.reference} version is not valid JSON: {e}", file=sys.stderr)
        return 2
    if cmp.identical and ref == path.read_bytes():
        print(f"{rel.as_posix()} reproduces the {args.reference} version byte for byte.")
        return 0
    print(f"{rel.as_posix()} differs from the {args.reference} version.\n{cmp.text()}")
    env_rel = rel.with_name("environment.json").as_posix()
    env_ref, env_now = committed_file(root, env_rel, args.reference), path.with_name("environment.json")
    if env_ref is not None and env_now.is_file():
        lines = describe_environment_change(json.loads(env_ref), json.loads(env_now.read_text(encoding="utf-8")))
        print("Environment against the reference: " + ("; ".join(lines) if lines else "the same"))
    return 1 if args.check else 0


def main(argv: list[str] | None = None) -> int:
    """Run one command; a user-fixable error is one line on stderr and exit status 2."""
    from interllm.errors import UserError, output_error  # lazy: a command loads only its own code

    try:
        return _main(argv)
    except UserError as e:
        print(f"interllm: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        if (unwritable := output_error(e)) is None:  # a bug: its traceback
            raise
        print(f"interllm: error: {unwritable}", file=sys.stderr)  # a full disk, a read-only folder
        return 2


def _out_folder(out: str) -> Path:
    """The --out folder of a command that writes several files; an existing file there is an error
    (and is left as it is)."""
    from interllm.errors import OutputError  # lazy: a command loads only its own code

    path = Path(out)
    if path.exists() and not path.is_dir():
        raise OutputError(f"--out {out} is an existing file, not a folder; name a folder for the command's "
                          f"files (e.g. --out my_scene/); {out} is left as it is")
    return path


def _llm_probe(args) -> int:
    """What the configured LLM backend does: the conformance probe of a server, or its identity."""
    import yaml  # lazy: a command loads only its own code

    from interllm.config import from_dict  # lazy: a command loads only its own code
    from interllm.llm.backend import make_backend  # lazy: a command loads only its own code
    from interllm.overrides import apply_overrides  # lazy: a command loads only its own code

    params = Path(args.params)
    raw = yaml.safe_load(params.read_text(encoding="utf-8")) or {} if params.is_file() else {}
    note = apply_overrides(raw, args.overrides)
    if note:
        print(note, file=sys.stderr)
    cfg = from_dict(raw, source=f"{params} and the overrides")
    backend = make_backend(cfg.llm)
    try:
        probe = getattr(backend, "probe", None)
        out = probe().to_dict() if probe is not None else {"backend": backend.name, "model": backend.model_name(),
                                                           "model_id": backend.model_id()}
    finally:
        backend.close()
    print(json.dumps(out, indent=1, sort_keys=True))
    return 0


def _main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "replay":
        from interllm.metrics.compute import run_log_object_rows  # lazy: a command loads only its own code
        from interllm.record.replay import replay_main  # lazy: a command loads only its own code

        return replay_main(argv[1:], metric_rows=run_log_object_rows)
    ap = argparse.ArgumentParser(prog="interllm", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("replay", help="replay an MCAP run (or a folder of runs) in rerun")
    sc = sub.add_parser("scene", help="scene tools").add_subparsers(dest="scmd", required=True)
    sc.add_parser("schema", help="print the scene JSON Schema")
    g = sc.add_parser("generate", help="generate a house")
    g.add_argument("--size", default="paper")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--assets", default="catalog", help="catalog (one size per category) or procthor (ProcTHOR's "
                                                       "asset database: real sizes, chairs around tables)")
    g.add_argument("--out", required=True)
    v = sc.add_parser("validate", help="validate a scene JSON file")
    v.add_argument("file")
    im = sc.add_parser("import-procthor", help="convert a ProcTHOR house JSON")
    im.add_argument("file")
    im.add_argument("--out", required=True)
    im.add_argument("overrides", nargs="*", help="Hydra overrides as for pipeline.run, e.g. sim/robot=stretch: "
                                                 "reachability and the reach report are for that robot")
    im.add_argument("--strict", action="store_true",
                    help="reject a child far off its parent and unreachable furniture (for authors of their "
                         "own houses) instead of repairing them")
    rc = sc.add_parser("reach", help="the objects the robot can pick up, per furniture category, and why not")
    rc.add_argument("file")
    rc.add_argument("overrides", nargs="*", help="Hydra overrides as for pipeline.run, e.g. sim/robot=stretch")
    rc.add_argument("--json", help="also write the report as JSON to this file")
    rp = sub.add_parser("report", help="the report, with the ablation results of Hydra multiruns")
    rp.add_argument("--data", default="data", help="folder with metrics/, scenes/, runs/")
    rp.add_argument("--params", default="params.yaml")
    rp.add_argument("--sweeps", nargs="*", default=["multirun"], help="Hydra multirun folders to gather")
    rp.add_argument("--out", default="data/report_sweeps")
    ca = sub.add_parser("cache", help="LLM response cache tools").add_subparsers(dest="ccmd", required=True)
    st = ca.add_parser("stats")
    st.add_argument("--dir", default="data/llm_cache")
    pu = ca.add_parser("prune", help="drop the entries that no call log names (what the committed runs used)")
    pu.add_argument("--dir", default="data/llm_cache")
    pu.add_argument("--keep", nargs="+", required=True, help="globs of llm_calls.jsonl call logs whose keys stay")
    pu.add_argument("--delete", action="store_true", help="remove them (default: only count)")
    rs = sub.add_parser("results", help="compare results").add_subparsers(dest="rcmd", required=True)
    rd = rs.add_parser("diff", help="metrics.json against a git revision's: what moved, which conclusions changed")
    rd.add_argument("--reference", default="HEAD", help="git revision (default HEAD)")
    rd.add_argument("--file", nargs="+", default=["data/metrics/metrics.json"],
                    help="metrics.json files to compare (default: the default experiment's); e.g. "
                         "data/sweeps/*/*/data/metrics/metrics.json data/mechanism/*/metrics/metrics.json")
    rd.add_argument("--repo", default=".", help="repository root (default: the current directory)")
    rd.add_argument("--check", action="store_true", help="exit 1 when the results differ")
    lm = sub.add_parser("llm", help="LLM backend tools").add_subparsers(dest="lcmd", required=True)
    pr = lm.add_parser("probe", help="what the configured backend's server does (JSON schema, log-probabilities, "
                                     "seed, context length, fingerprint)")
    pr.add_argument("overrides", nargs="*", help="config overrides key=value, e.g. llm.backend=openai")
    pr.add_argument("--params", default="params.yaml")
    args = ap.parse_args(argv)
    if args.cmd == "llm":
        return _llm_probe(args)
    if args.cmd == "results":
        return _results_diff(args)
    if args.cmd == "scene":
        if args.scmd == "schema":
            from interllm.scene.schema import scene_json_schema  # lazy: a command loads only its own code

            print(json.dumps(scene_json_schema(), indent=2))
            return 0
        return {"generate": _scene_generate, "validate": _scene_validate,
                "import-procthor": _scene_import, "reach": _scene_reach}[args.scmd](args)
    if args.cmd == "cache":
        return _cache_prune(args) if args.ccmd == "prune" else _cache_stats(args)
    if args.cmd == "report":
        return _report(args)
    return 2


if __name__ == "__main__":
    sys.exit(main())
