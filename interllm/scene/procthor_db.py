"""ProcTHOR's own asset database, read from the PyPI package ``procthor`` (0.0.1.dev2).

The package ships ``procthor/databases/``; this module reads the parts the scenes use, checks them
and returns frozen records. It never imports ``procthor.databases`` (that module imports AI2-THOR's
controller and may fetch more data through ``prior``): it finds the package's folder with
``importlib.util.find_spec`` and reads the JSON files itself, so nothing is downloaded at run time.
``make install`` installs the package without its dependencies (numpy, matplotlib, trimesh,
python-sat: only its own house generator needs them).

What is read (sizes in metres; ProcTHOR's x-z floor becomes our x-y, its y our z):

- ``asset-database.json``: 1,653 assets of 109 object types, each with its bounding box
  (``AssetRecord.size``: x, depth, height in the asset's own frame) and ``primaryProperty``
  (``CanPickup`` for objects a hand can take);
- ``receptacles.json``: for each receptacle type, which object types stand on it in AI2-THOR's
  hand-made scenes, with counts and frequencies (``receptacle_objects``);
- ``placement-annotations.json``: per object type, in which room types it appears (0: never,
  1: sometimes, 2: often) and whether it stands on the floor, against a wall, in a corner;
- ``asset_groups/*.json``: groups placed together, e.g. ``chair-diningtable-4`` (a table and four
  chairs) as each member's position relative to the group's first member [m] and yaw [deg].

Counter assets carry their shape and size in their id: ``Countertop_L_10x4`` is an L of 10 by 4
feet (``counter_shape``); the shape is what ``furniture_parts`` turns into boxes.
"""

from __future__ import annotations

import importlib.util
import json
import re
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from interllm.errors import UserError

PACKAGE = "procthor"
VERSION = "0.0.1.dev2"
INSTALL_HINT = f"`make install` installs it, or: pip install --no-deps {PACKAGE}=={VERSION}"
ROOM_KEYS = {"kitchen": "inKitchens", "living_room": "inLivingRooms", "bedroom": "inBedrooms",
             "bathroom": "inBathrooms"}  # our room types -> placement-annotations.json columns
FOOT = 0.3048  # [m]: counter ids give their size in feet
COUNTER_DEPTH_FT = 2  # an L or C counter's arms are 2 ft deep (Countertop_I_*x2 is the straight piece)
_COUNTER_ID = re.compile(r"^Countertop_(C|I|L|Island)_(\d+)x(\d+)$")


class ProcthorDatabaseError(UserError, RuntimeError):
    """The ``procthor`` package is missing, or a database file it ships is not what this module reads."""


@dataclass(frozen=True)
class AssetRecord:
    """One asset of ``asset-database.json``.

    size: bounding box (x, depth, height) [m] in the asset's frame (ProcTHOR's x, z, y).
    pickupable: ``primaryProperty == "CanPickup"``.
    """

    id: str
    object_type: str
    size: tuple[float, float, float]
    pickupable: bool


@dataclass(frozen=True)
class GroupMember:
    """One member of an asset group: its object type, the assets it may be, and where it stands
    relative to the group's first member (``offset`` [m], ProcTHOR x and z) with its ``yaw`` [deg]."""

    object_type: str
    asset_ids: tuple[str, ...]
    offset: tuple[float, float]
    yaw: float


@dataclass(frozen=True)
class ProcthorDatabase:
    """The parts of ProcTHOR's database the scenes use (module doc)."""

    folder: Path
    assets: dict[str, AssetRecord]  # asset id -> record
    receptacles: dict[str, dict[str, float]]  # receptacle type -> {object type: frequency}
    rooms: dict[str, dict[str, int]]  # object type -> {our room type: 0 never, 1 sometimes, 2 often}
    groups: dict[str, tuple[GroupMember, ...]]  # group name (file stem) -> members, the anchor first

    def assets_of(self, object_type: str) -> tuple[AssetRecord, ...]:
        """The assets of ``object_type``, sorted by id; a clear error naming valid types if none."""
        out = tuple(a for a in sorted(self.assets.values(), key=lambda a: a.id) if a.object_type == object_type)
        if not out:
            types = sorted({a.object_type for a in self.assets.values()})
            raise ProcthorDatabaseError(f"no asset of type {object_type!r} in {self.folder / 'asset-database.json'}; "
                                        f"valid types: {types}")
        return out

    @property
    def pickupable_types(self) -> tuple[str, ...]:
        """Object types with at least one ``CanPickup`` asset, sorted."""
        return tuple(sorted({a.object_type for a in self.assets.values() if a.pickupable}))

    def receptacle_objects(self, receptacle_type: str) -> dict[str, float]:
        """{object type: frequency} of what stands on ``receptacle_type`` ({} when the database has no
        statistics for it)."""
        return dict(self.receptacles.get(receptacle_type, {}))

    def room_frequency(self, object_type: str, room_type: str) -> int:
        """0 (never), 1 (sometimes) or 2 (often): how often ``object_type`` appears in ``room_type``
        (0 for room types the annotations do not have, e.g. hallways)."""
        return int(self.rooms.get(object_type, {}).get(room_type, 0))


def database_folder() -> Path:
    """``procthor/databases`` of the installed package, found without importing it."""
    spec = importlib.util.find_spec(PACKAGE)
    if spec is None or not spec.submodule_search_locations:
        raise ProcthorDatabaseError(f"ProcTHOR's asset database needs the PyPI package {PACKAGE} "
                                    f"({VERSION}); {INSTALL_HINT}")
    folder = Path(next(iter(spec.submodule_search_locations))) / "databases"
    if not (folder / "asset-database.json").is_file():
        raise ProcthorDatabaseError(f"{folder}: no asset-database.json; the installed {PACKAGE} is not the "
                                    f"release this project reads ({VERSION}); {INSTALL_HINT}")
    return folder


@cache
def load_database(folder: Path | None = None) -> ProcthorDatabase:
    """Read and check the database (module doc); ``folder`` defaults to the installed package's."""
    folder = Path(folder) if folder is not None else database_folder()
    return ProcthorDatabase(folder=folder, assets=_assets(folder), receptacles=_receptacles(folder),
                            rooms=_rooms(folder), groups=_groups(folder))


def counter_shape(asset_id: str) -> tuple[str, float, float] | None:
    """(shape, x [m], depth [m]) of a counter asset id (``Countertop_L_10x4`` -> ("L", 3.048, 1.219));
    None for other ids. Shapes: "I" (straight), "L", "C" (a U), "Island"."""
    m = _COUNTER_ID.match(asset_id)
    if m is None:
        return None
    return m.group(1), int(m.group(2)) * FOOT, int(m.group(3)) * FOOT


def _read(folder: Path, name: str):
    path = folder / name
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ProcthorDatabaseError(f"{path}: missing; {INSTALL_HINT}") from None
    except (OSError, ValueError) as e:
        raise ProcthorDatabaseError(f"{path}: not readable JSON ({e}); reinstall it: {INSTALL_HINT}") from None


def _bad(folder: Path, name: str, where: str, problem: str) -> ProcthorDatabaseError:
    return ProcthorDatabaseError(f"{folder / name}: {where}: {problem}; this module reads {PACKAGE} {VERSION} "
                                 f"({INSTALL_HINT})")


def _assets(folder: Path) -> dict[str, AssetRecord]:
    name = "asset-database.json"
    raw = _read(folder, name)
    if not isinstance(raw, dict):
        raise _bad(folder, name, "$", "expected an object of object types")
    out = {}
    for otype, assets in raw.items():
        for i, a in enumerate(assets if isinstance(assets, list) else []):
            try:
                bb = a["boundingBox"]
                size = (float(bb["x"]), float(bb["z"]), float(bb["y"]))
                aid = str(a["assetId"])
            except (KeyError, TypeError, ValueError) as e:
                raise _bad(folder, name, f"$.{otype}[{i}]", f"no assetId or boundingBox x/y/z ({e})") from None
            if min(size) <= 0:
                raise _bad(folder, name, f"$.{otype}[{i}].boundingBox", f"sizes must be > 0, got {size}")
            out[aid] = AssetRecord(aid, str(a.get("objectType", otype)), size,
                                   a.get("primaryProperty") == "CanPickup")
    if not out:
        raise _bad(folder, name, "$", "no assets")
    return out


def _receptacles(folder: Path) -> dict[str, dict[str, float]]:
    name = "receptacles.json"
    raw = _read(folder, name)
    try:
        return {r: {o: float(v["p"]) for o, v in sorted(objs.items())} for r, objs in sorted(raw.items())}
    except (AttributeError, KeyError, TypeError, ValueError) as e:
        raise _bad(folder, name, "$", f"expected {{receptacle: {{object: {{count, p}}}}}} ({e})") from None


def _rooms(folder: Path) -> dict[str, dict[str, int]]:
    name = "placement-annotations.json"
    raw = _read(folder, name)
    missing = [k for k in ROOM_KEYS.values() if not isinstance(raw, dict) or not isinstance(raw.get(k), dict)]
    if missing:
        raise _bad(folder, name, "$", f"missing the columns {missing}")
    types = sorted({t for k in ROOM_KEYS.values() for t in raw[k]})
    return {t: {room: int(raw[k].get(t) or 0) for room, k in ROOM_KEYS.items()} for t in types}


def _groups(folder: Path) -> dict[str, tuple[GroupMember, ...]]:
    out = {}
    for path in sorted((folder / "asset_groups").glob("*.json")):
        name = f"asset_groups/{path.name}"
        raw = _read(folder, name)
        try:
            members = list(raw["assetMetadata"].values())
            anchor = next(m for m in members if "parentInstanceId" not in m)
            ax, az = anchor["___cache"]["globalXMeters"], anchor["___cache"]["globalZMeters"]
            ordered = [anchor] + [m for m in members if m is not anchor]
            out[path.stem] = tuple(
                GroupMember(m["name"], tuple(sorted(a for ids in m["assetIds"].values() for a in ids)),
                            (round(m["___cache"]["globalXMeters"] - ax, 4),
                             round(m["___cache"]["globalZMeters"] - az, 4)), float(m.get("rotation", 0)))
                for m in ordered)
        except (KeyError, TypeError, StopIteration, AttributeError) as e:
            raise _bad(folder, name, "$.assetMetadata", f"not an asset group ({type(e).__name__}: {e})") from None
    return out
