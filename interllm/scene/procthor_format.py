"""Reading ProcTHOR's house format: the names it uses and what they become, the checked access to
its fields (errors name the JSON path), the report of what an import defaulted or dropped, and the
state one conversion carries (``Conversion``)."""

from __future__ import annotations

import re
from collections import defaultdict
from dataclasses import dataclass, field
from typing import Any

from interllm.scene.catalog import Catalog
from interllm.scene.validate import SceneValidationError

ROOM_TYPES = {"kitchen": "kitchen", "livingroom": "living_room", "bedroom": "bedroom", "bathroom": "bathroom",
              "diningroom": "dining_room", "office": "study", "study": "study", "laundryroom": "laundry_room"}
ALIASES = {"countertop": "kitchen_counter", "shelvingunit": "bookshelf", "shelf": "bookshelf",
           "tvstand": "tv_stand", "diningtable": "dining_table", "coffeetable": "coffee_table",
           "sidetable": "side_table", "armchair": "armchair", "cellphone": "cellphone", "houseplant": "house_plant",
           "remotecontrol": "remote_control", "sinkbasin": "sink", "garbagecan": "garbage_can",
           "keychain": "key_chain", "creditcard": "credit_card", "soapbottle": "soap_bottle",
           "spraybottle": "spray_bottle", "dishsponge": "dish_sponge", "toiletpaper": "toilet_paper",
           "tissuebox": "tissue_box", "desklamp": "desk_lamp", "floorlamp": "floor_lamp", "dogbed": "dog_bed",
           "laundryhamper": "laundry_hamper", "clothesdryer": "clothes_dryer", "washingmachine": "washing_machine",
           "alarmclock": "alarm_clock", "waterbottle": "water_bottle", "footstool": "ottoman",
           "walldecor": "painting", "wallphoto": "painting"}
CHILD_ALIASES = {"house_plant": "small_plant"}  # a plant standing on furniture is a small one
# Types ProcTHOR hangs on walls (its wall-object pass: windows, paintings, wall televisions) or fixes
# to them: never floor obstacles. A television that is a child (on a TV stand) is an object.
WALL_MOUNTED = {"painting", "television", "window", "blinds", "mirror", "light_switch", "towel_holder",
                "hand_towel_holder", "toilet_paper_hanger", "doorframe", "doorway"}


@dataclass
class ImportReport:
    """What an import defaulted, dropped or moved: {reason: [item, ...]}."""

    items: dict[str, list[str]] = field(default_factory=lambda: defaultdict(list))
    warnings: list[str] = field(default_factory=list)  # what changes the house as a whole, said first

    def add(self, reason: str, item: str) -> None:
        self.items[reason].append(item)

    def warn(self, text: str) -> None:
        self.warnings.append(text)

    def lines(self, examples: int = 3) -> list[str]:
        """The warnings (``warning: ...``), then one line per reason: ``<count> × <reason> (e.g. a, b,
        c)``, sorted by reason."""
        out = [f"warning: {w}" for w in self.warnings]
        for reason in sorted(self.items):
            got = self.items[reason]
            uniq = list(dict.fromkeys(got))
            more = ", ..." if len(uniq) > examples else ""
            out.append(f"{len(got)} × {reason} (e.g. {', '.join(uniq[:examples])}{more})")
        return out


def snake_case(name: str) -> str:
    """``LivingRoom`` -> ``living_room``."""
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()


def type_name(o: dict) -> str:
    """ProcTHOR's object type: the alphabetic prefix of the id (``Sofa|2|1``), else of the assetId
    (``Sofa_208_1``, ``Wall_Decor_Painting_6``), else "object"."""
    head = str(o.get("id", "")).split("|")[0]
    if head.isalpha() and head.lower() not in ("small", "surface"):
        return head
    asset = str(o.get("assetId", ""))
    parts = [p for p in asset.split("_") if p.isalpha()]
    if parts[:2] == ["Wall", "Decor"]:  # Wall_Decor_Painting_6, Wall_Decor_Photo_3V
        return "WallDecor"
    return parts[0] if parts else "object"


def category_of(tname: str, known: dict) -> tuple[str, bool]:
    """(our category, whether ``known``, the catalog's furniture or objects, has it) of a ProcTHOR
    type name."""
    key = tname.replace("_", "").lower()
    name = ALIASES.get(key, snake_case(tname))
    return name, name in known


def xz_point(p: Any, source: str, path: str) -> tuple[float, float]:
    """(x, z) [m] of a ProcTHOR point {x, y, z} at JSON ``path``: our (x, y)."""
    if not isinstance(p, dict) or "x" not in p or "z" not in p:
        raise SceneValidationError(source, path, "expected a point {x, y, z} with keys x and z")
    return float(p["x"]), float(p["z"])


def required(d: dict, key: str, source: str, path: str) -> Any:
    """``d[key]``; a missing key is a ``SceneValidationError`` naming ``path.key``."""
    if not isinstance(d, dict) or key not in d:
        raise SceneValidationError(source, f"{path}.{key}", "required field is missing")
    return d[key]


def seg_key(a, b) -> tuple:
    """The segment a-b as a key, its ends rounded to 1 mm and sorted (the same for b-a)."""
    return tuple(sorted([(round(a[0], 3), round(a[1], 3)), (round(b[0], 3), round(b[1], 3))]))


@dataclass(frozen=True)
class ImportOptions:
    """How forgiving an import is. strict: reject a child far off its parent, and (in ``validate_scene``)
    unreachable furniture, as a house author wants; else repair them (``interllm.scene.repair``).
    robot_radius [m], resolution [m/cell]: the grid on which reachability is judged.
    objects_per_command: the reachable objects a command needs to be hostable."""

    strict: bool = False
    robot_radius: float = 0.25
    resolution: float = 0.05
    objects_per_command: int = 3


class IdCounter:
    """Our ids of one house: ``<kind>_1``, ``<kind>_2``, ... per kind, in the order they are asked for."""

    def __init__(self) -> None:
        self.counters: dict[str, int] = {}

    def new(self, kind: str) -> str:
        self.counters[kind] = self.counters.get(kind, 0) + 1
        return f"{kind}_{self.counters[kind]}"


@dataclass
class Conversion:
    """One import under way: where the house came from (``source``, for messages), the catalog, the
    report, the options, our ids, and ``at``: the JSON path being converted, kept up to date for the
    message when a field has the wrong type."""

    source: str
    cat: Catalog
    rep: ImportReport
    opts: ImportOptions
    ids: IdCounter = field(default_factory=IdCounter)
    at: str = "$"
