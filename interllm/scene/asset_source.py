"""Which real thing a generated piece is (``scene.assets``): one size per category, or a ProcTHOR asset.

``CatalogSizes`` (``scene.assets=catalog``): every piece of a category has the catalog's size
(``catalog/*.json``) and nothing is drawn, so catalog houses keep their bytes.

``ProcthorAssets`` (``scene.assets=procthor``), from ProcTHOR's own database (``procthor_db``):

- **Sizes.** A piece whose category maps to a ProcTHOR object type (``FURNITURE_TYPES``,
  ``OBJECT_TYPES``) is one asset of ``asset-database.json``, drawn uniformly among the type's assets
  with the attempt's generator (an object among the type's ``CanPickup`` assets) and recorded in the
  piece's ``asset``. Its footprint (x along its back,
  depth) and height are the asset's bounding box [m]. A seat's or bed's box top is no surface (a
  sofa's back, a headboard): their surface height stays the catalog's (``SEAT_TYPES``).
- **What stands where.** The random objects (``surface_objects.fill_budget``) of a host are drawn
  among the catalog's ``holds`` with weight = ``receptacles.json``'s frequency of the type on the
  host's type (``UNLISTED_WEIGHT`` when it lists none) times ``placement-annotations.json``'s room
  frequency (``ROOM_WEIGHT``; our room types without a column borrow one, ``ANNOTATION_ROOM``).
- **Chairs.** Dining tables and desks get chairs as ``asset_groups/`` lays them out
  (``chair-diningtable-2`` .. ``-7``, ``desk-with-chair``): each chair on the side the group puts it,
  as far from the table's edge as there, along the edge in proportion (``chair_spots``).

Where the database has no answer the catalog stays: the categories not in ``FURNITURE_TYPES`` or
``OBJECT_TYPES`` (``catalog_only()``) keep the catalog's size, the commands' categories and targets
stay the catalog's, and the ``holds`` lists still say which categories a furniture may hold at all.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from interllm.scene.catalog import Catalog
from interllm.scene.procthor_db import PACKAGE, VERSION, ProcthorDatabase, load_database

# our furniture category -> (ProcTHOR object type, asset id prefix the category takes, or "")
FURNITURE_TYPES = {
    "dining_table": ("DiningTable", ""), "kitchen_counter": ("CounterTop", "Countertop_I_"),
    "kitchen_island": ("CounterTop", "Countertop_Island_"), "pantry_shelf": ("ShelvingUnit", ""),
    "bookshelf": ("ShelvingUnit", ""), "desk": ("Desk", ""), "coffee_table": ("CoffeeTable", ""),
    "sofa": ("Sofa", ""), "armchair": ("ArmChair", ""), "tv_stand": ("TVStand", ""),
    "side_table": ("SideTable", ""), "nightstand": ("SideTable", ""), "bed": ("Bed", ""),
    "dresser": ("Dresser", ""), "chair": ("Chair", ""), "stool": ("Stool", ""), "toilet": ("Toilet", ""),
    "fridge": ("Fridge", ""), "garbage_can": ("GarbageCan", ""), "house_plant": ("HousePlant", ""),
    "floor_lamp": ("FloorLamp", ""), "dog_bed": ("DogBed", ""), "ottoman": ("Ottoman", ""),
    "laundry_hamper": ("LaundryHamper", ""), "clothes_dryer": ("ClothesDryer", ""),
    "washing_machine": ("WashingMachine", ""), "box": ("Box", ""), "safe": ("Safe", ""),
}
SEAT_TYPES = frozenset({"Sofa", "ArmChair", "Bed", "Chair", "Toilet"})  # box top is a back or headboard
OBJECT_TYPES = {
    "bread": "Bread", "apple": "Apple", "egg": "Egg", "bowl": "Bowl", "plate": "Plate", "mug": "Mug",
    "cup": "Cup", "laptop": "Laptop", "cellphone": "CellPhone", "pen": "Pen", "pencil": "Pencil",
    "book": "Book", "newspaper": "Newspaper", "remote_control": "RemoteControl", "alarm_clock": "AlarmClock",
    "statue": "Statue", "vase": "Vase", "pillow": "Pillow", "key_chain": "KeyChain",
    "credit_card": "CreditCard", "watch": "Watch", "candle": "Candle", "spoon": "Spoon", "fork": "Fork",
    "knife": "Knife", "tomato": "Tomato", "potato": "Potato", "lettuce": "Lettuce",
    "soap_bottle": "SoapBottle", "spray_bottle": "SprayBottle", "dish_sponge": "DishSponge",
    "toilet_paper": "ToiletPaper", "tissue_box": "TissueBox", "desk_lamp": "DeskLamp", "cd": "CD",
    "pan": "Pan", "pot": "Pot", "kettle": "Kettle", "soap": "SoapBar",
}
# our room types without a column in placement-annotations.json -> the column they borrow
ANNOTATION_ROOM = {"dining_room": "living_room", "study": "bedroom", "laundry_room": "bathroom",
                   "home_gym": "bedroom", "playroom": "bedroom", "hallway": "living_room"}
ROOM_WEIGHT = (0.25, 1.0, 2.0)  # weight of an object type the room annotation says never, sometimes, often has
UNLISTED_WEIGHT = 0.02  # receptacles.json frequency given to a type it never saw on the host's type
DINING_GROUPS = tuple(f"chair-diningtable-{n}" for n in range(2, 8))
DESK_GROUP = "desk-with-chair"
CHAIR_GROUPS = {"dining_table": DINING_GROUPS, "desk": (DESK_GROUP,)}
PROCTHOR_META = f"{PACKAGE} {VERSION} asset database"  # scene.meta["assets"] of a house built from it


@dataclass(frozen=True)
class Drawn:
    """A piece's size: (x along its back, depth, surface height) [m], and the asset id ("": catalog)."""

    size: tuple[float, float, float]
    asset: str = ""


@dataclass(frozen=True)
class ChairSpot:
    """A chair of a group, in its table's frame (x along the table's first side, y its depth):
    ``offset`` of its centre from the table's centre [m], its ``size`` (x, y) [m] in that frame
    (turned with its ``yaw``), and its asset id."""

    offset: tuple[float, float]
    size: tuple[float, float]
    asset: str


class CatalogSizes:
    """``scene.assets=catalog``: the catalog's size for every piece, nothing drawn (module doc)."""

    def __init__(self, cat: Catalog) -> None:
        self.cat = cat

    def furniture(self, category: str, rng: np.random.Generator) -> Drawn:
        return Drawn(tuple(self.cat.furniture[category].size))

    def object(self, category: str, rng: np.random.Generator) -> Drawn:
        return Drawn(tuple(self.cat.objects[category].size))

    def object_weights(self, host_category: str, room_type: str, holds: tuple[str, ...]) -> Optional[np.ndarray]:
        return None  # uniform over holds

    def chairs(self, category: str, size: tuple[float, float], rng: np.random.Generator) -> list[ChairSpot]:
        return []


class ProcthorAssets(CatalogSizes):
    """``scene.assets=procthor``: real assets, chairs from asset groups, weighted objects (module doc)."""

    def __init__(self, cat: Catalog, db: ProcthorDatabase) -> None:
        super().__init__(cat)
        self.db = db
        self._furniture = {c: tuple(a for a in db.assets_of(t) if a.id.startswith(prefix))
                           for c, (t, prefix) in FURNITURE_TYPES.items()}
        self._objects = {c: tuple(a for a in db.assets_of(t) if a.pickupable) or db.assets_of(t)
                         for c, t in OBJECT_TYPES.items()}  # the CanPickup assets where the type has any

    def furniture(self, category: str, rng: np.random.Generator) -> Drawn:
        pool = self._furniture.get(category)
        if not pool:
            return super().furniture(category, rng)
        a = pool[int(rng.integers(len(pool)))]
        height = self.cat.furniture[category].size[2] if a.object_type in SEAT_TYPES else a.size[2]
        return Drawn((a.size[0], a.size[1], height), a.id)

    def object(self, category: str, rng: np.random.Generator) -> Drawn:
        pool = self._objects.get(category)
        if not pool:
            return super().object(category, rng)
        a = pool[int(rng.integers(len(pool)))]
        return Drawn(a.size, a.id)

    def object_weights(self, host_category: str, room_type: str, holds: tuple[str, ...]) -> Optional[np.ndarray]:
        """Weights (sum 1) of ``holds`` as the random objects of a ``host_category`` in a ``room_type``."""
        host = FURNITURE_TYPES.get(host_category, ("", ""))[0]
        freq = self.db.receptacle_objects(host)
        room = ANNOTATION_ROOM.get(room_type, room_type)
        w = np.array([max(freq.get(OBJECT_TYPES.get(c, ""), 0.0), UNLISTED_WEIGHT)
                      * ROOM_WEIGHT[self.db.room_frequency(OBJECT_TYPES.get(c, ""), room)]
                      if c in OBJECT_TYPES else UNLISTED_WEIGHT * ROOM_WEIGHT[1] for c in holds])
        return w / w.sum()

    def chairs(self, category: str, size: tuple[float, float], rng: np.random.Generator) -> list[ChairSpot]:
        """The chairs of one drawn group for a ``category`` piece of footprint ``size`` (x, depth) [m];
        [] for categories without a group, or when the group's chairs would overlap on this piece."""
        groups = CHAIR_GROUPS.get(category)
        if not groups:
            return []
        spots = chair_spots(self.db, groups[int(rng.integers(len(groups)))], size, rng)
        return spots if not _overlapping(spots) else []

    @staticmethod
    def catalog_only(cat: Catalog) -> tuple[list[str], list[str]]:
        """(furniture, object) categories of ``cat`` that keep the catalog's size (no ProcTHOR type)."""
        return (sorted(c for c in cat.furniture if c not in FURNITURE_TYPES),
                sorted(c for c in cat.objects if c not in OBJECT_TYPES))


def asset_source(name: str, cat: Catalog) -> CatalogSizes:
    """The source ``scene.assets`` names (``ASSET_SOURCES``)."""
    return ProcthorAssets(cat, load_database()) if name == "procthor" else CatalogSizes(cat)


def chair_spots(db: ProcthorDatabase, group: str, size: tuple[float, float],
                rng: np.random.Generator) -> list[ChairSpot]:
    """The chairs of asset group ``group`` around a piece of footprint ``size`` (x, depth) [m].

    The group is laid out around its own table (the median of its table assets): a chair beyond the
    table's edge along an axis keeps its distance to that edge; a chair within it keeps its share of
    the half-length. One chair asset, drawn among the group's, serves every chair."""
    anchor, *members = db.groups[group]
    sizes = np.array([db.assets[a].size[:2] for a in anchor.asset_ids if a in db.assets])
    half_group = np.median(sizes, axis=0) / 2
    half = np.array(size, dtype=float) / 2
    chair_ids = [a for a in members[0].asset_ids if a in db.assets] if members else []
    if not chair_ids:
        return []
    chair = db.assets[chair_ids[int(rng.integers(len(chair_ids)))]]
    out = []
    for m in members:
        off = np.array(m.offset, dtype=float)
        beyond = np.abs(off) >= half_group
        off = np.where(beyond, off + np.sign(off) * (half - half_group), off * half / half_group)
        turned = round(m.yaw) % 180 == 90
        cs = (chair.size[1], chair.size[0]) if turned else (chair.size[0], chair.size[1])
        out.append(ChairSpot((float(off[0]), float(off[1])), cs, chair.id))
    return out


def _overlapping(spots: list[ChairSpot]) -> bool:
    """True when two chairs' footprints overlap."""
    boxes = [(s.offset[0] - s.size[0] / 2, s.offset[1] - s.size[1] / 2,
              s.offset[0] + s.size[0] / 2, s.offset[1] + s.size[1] / 2) for s in spots]
    return any(a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]
               for i, a in enumerate(boxes) for b in boxes[i + 1:])
