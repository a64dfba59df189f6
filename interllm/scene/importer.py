"""Import a ProcTHOR house (schema 1.0.0, as ``allenai/procthor`` writes it) into a SceneGraph.

ProcTHOR's floor is the x-z plane with y up; we map (x, z) -> (x, y) and y -> z. What each part of
the house becomes (every defaulted or dropped item is counted in the ``ImportReport``, one line per
reason, never one warning per item):

- ``rooms[i]``: ``id``, ``roomType`` (Kitchen, LivingRoom, Bedroom, Bathroom; others by name),
  ``floorPolygon`` [{x, y, z}] -> a room with that polygon.
- ``walls[i]``: ``id`` ``wall|<room>|x0|z0|x1|z1``, ``polygon``. A wall shared by two rooms is
  listed once per room and imported once; the ``wall|exterior|...`` copies are skipped. A wall
  with ``"empty": true`` is ProcTHOR's open connection between two rooms: no wall, and an opening
  as wide as the shared edge joins the rooms. A house with no walls gets them from its room
  polygons: every edge not shared by two rooms, and every shared edge with a door of the file on it
  (cut at the door); a shared edge without a door is an open connection (so a house with neither
  walls nor doors is fully open inside, and the report says so).
- ``doors[i]``: ``room0``, ``room1``, ``wall0``, ``holePolygon`` (x along the wall from its first
  polygon point [m]) or ``assetPosition``, ``openable`` / ``openness`` (doorframes, without them,
  are open). A door with ``room0 == room1`` leads outside: dropped (the outside is not on the map),
  its wall stays closed. A door closed in the file (openness 0) stays closed: our robot does not
  open doors. ``windows`` are ignored.
- ``objects[i]``: the type comes from the id prefix (``Sofa|2|1``) or else the ``assetId`` prefix;
  the footprint and height from ``axisAlignedBoundingBox.size`` when the file has it, else from
  the catalog's size turned by ``rotation.y``; ``position`` is the box centre. Wall-mounted types
  (paintings, televisions on the wall, ...) are kept off the floor grid (not imported, nor their
  children). ``children`` are absolute world positions: each is put on its parent's top surface,
  moved inside the parent's footprint when its box would stick out. Types not in the catalog keep
  their box (or a default one) and their snake_case name as category.

Untidy houses are repaired, not rejected (``interllm.scene.repair``; ``ImportOptions(strict=True)``,
``interllm scene import-procthor --strict``, rejects them as a house author wants): a parent whose
child lies off its footprint is checked against its rotation and its ``axisAlignedBoundingBox``; a child
more than ``CHILD_SLACK`` off its parent goes to the nearest surface, the floor, or is dropped;
furniture the robot cannot reach is kept, marked unreachable, and left out of missions. The house is
rejected only when a child cannot be repaired (all listed). A house that hosts no command of the catalog
is imported with a warning naming the commands generated from what it holds (``open_commands``), which
its missions then draw; one that hosts no command at all is imported with a warning too.

The conversion's stages: ``procthor_format`` (names, checked fields, the report, ids),
``procthor_layout`` (rooms, walls, doors), ``procthor_objects`` (furniture and their children), then
the repairs of ``repair``.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Optional

from interllm.io import NAME_MAX, InputFileError, read_json
from interllm.scene.catalog import Catalog, load_catalog
from interllm.scene.graph import SceneGraph
from interllm.scene.open_commands import open_commands
from interllm.scene.procthor_format import Conversion, ImportOptions, ImportReport
from interllm.scene.procthor_layout import convert_floor_map
from interllm.scene.procthor_objects import convert_objects
from interllm.scene.repair import mark_unreachable, warn_unhostable
from interllm.scene.validate import SceneValidationError, check_scene_id, check_scene_size, looks_like_scene

SCHEMA = "1.0.0"  # metadata.schema of the houses this importer reads


def import_procthor(house: str | Path | dict, catalog: Catalog | None = None, scene_id: str | None = None,
                    wall_thickness: float = 0.1, report: Optional[ImportReport] = None,
                    opts: Optional[ImportOptions] = None) -> SceneGraph:
    """Convert a ProcTHOR house (path to JSON or dict) into a SceneGraph (see module docstring).

    scene_id: default the house's ``id``, else the file's name (``procthor_house`` for a dict).
    report: filled with what was defaulted, dropped, moved or repaired (also in
    ``scene.meta["import_report"]``), and a house of another ``metadata.schema`` than 1.0.0.
    opts: ``ImportOptions`` (default: repair untidy houses; ``strict=True``: reject them).
    Raises ``SceneValidationError`` with the JSON path when a required field is missing or wrong, when
    the file is a scene in this project's format already, or (without strict) when children cannot be
    repaired (all listed). Which commands a house can host never refuses it (the report warns).
    """
    cat = catalog or load_catalog()
    rep = report if report is not None else ImportReport()
    if isinstance(house, dict):
        d, source = house, "<procthor house>"
    else:
        source = str(house)
        try:
            d = read_json(house)
        except InputFileError as e:
            raise SceneValidationError(source, "$", e.problem) from None
    if not isinstance(d, dict):
        raise SceneValidationError(source, "$", f"a ProcTHOR house is a JSON object, got {type(d).__name__}")
    if looks_like_scene(d):
        raise SceneValidationError(source, "$", f"this is already a scene in interllm's format, not a "
                                                f"ProcTHOR house: use it as it is, "
                                                f"scene.import_path={source} (check it with "
                                                f"`interllm scene validate {source}`)")
    _check_schema_version(d, rep)
    check_scene_size({k: d.get(k) for k in ("rooms", "objects")}, source)  # before the conversion's work
    if scene_id is not None:
        check_scene_id({"id": scene_id}, source, at="scene_id", fix="pass another scene_id")
    elif d.get("id"):
        check_scene_id(d, source, fix="set the house's id to a name like train_42, or remove it to name the scene "
                                      "after its file")
    if scene_id is None and not d.get("id") and not isinstance(house, dict):  # the file's name, not a default
        scene_id = re.sub(r"[^A-Za-z0-9_.-]+", "_", Path(house).stem).lstrip(".-")[:NAME_MAX] or None
    cv = Conversion(source, cat, rep, opts or ImportOptions())
    try:
        return _convert(d, cv, scene_id, wall_thickness)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as e:
        if isinstance(e, SceneValidationError):
            raise
        detail = f"missing field {e}" if isinstance(e, KeyError) else f"{type(e).__name__}: {e}"
        raise SceneValidationError(source, cv.at, f"a field has the wrong type or is missing ({detail}); "
                                   f"see ProcTHOR's house format") from None


def _check_schema_version(d: dict, rep: ImportReport) -> None:
    """A house of another ProcTHOR schema than the one this importer reads is converted all the same,
    with a line in the report (most fields keep their meaning across versions)."""
    meta = d.get("metadata")
    version = meta.get("schema") if isinstance(meta, dict) else None
    if version is not None and str(version) != SCHEMA:
        rep.add(f"schema {version!r}: not the ProcTHOR schema {SCHEMA} this importer knows; converted as "
                f"{SCHEMA}: check the result (topdown.png) and the lines above", "$.metadata.schema")


def _convert(d: dict, cv: Conversion, scene_id: str | None, wall_thickness: float) -> SceneGraph:
    """The scene of house ``d``: its floor map, then its furniture and objects, then (without strict)
    the reachability repairs."""
    rooms, room_map, walls, doors = convert_floor_map(d, cv, wall_thickness)
    furniture, objects, raw_ids, paths = convert_objects(d, cv, rooms)
    for k, rid in room_map.items():
        raw_ids[rid] = k
    scene = SceneGraph(id=scene_id or str(d.get("id") or "procthor_house"), seed=0, rooms=rooms, walls=walls,
                       doors=doors, furniture=furniture, objects=objects,
                       meta={"importer": "procthor", "source_ids": dict(sorted(raw_ids.items()))})
    opts = cv.opts
    if not opts.strict:
        cv.at = "$.objects"
        mark_unreachable(scene, opts.robot_radius, opts.resolution, cv.rep, paths)
        generated = [c.text for c in open_commands(scene, cv.cat)]
        warn_unhostable(scene, cv.cat, opts.objects_per_command, generated, cv.rep)
    scene.meta["import_report"] = cv.rep.lines()
    return scene
