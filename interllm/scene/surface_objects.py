"""Objects on the furniture of a generated house: one placement, the ``legacy`` object design and
the random fill up to ``scene.n_objects``.

An object rests on a furniture's top surface, inside its footprint by ``placement.surface_margin``
and ``placement.object_gap`` from the other objects there, with a placement label (thresholds in
``catalog/furniture.json``): *front* (near a free edge of the surface), *deep* (far from every free
edge), *high* (on a surface at or above ``high_min``) or *clutter* (right next to another object).

``scene.object_design=legacy``: each catalog command whose target furniture exists receives at
least ``min_objects_per_command`` valid objects (not on its own targets), spread over rooms where
possible, each placed hard (deep, high, clutter) with ``hard_placement_prob``; then random objects
up to ``n_objects``. The paper's three commands must get theirs (else the attempt is redrawn).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from interllm.scene.build_state import BuildState, Retry, SceneGenerationError
from interllm.scene.geometry import free_edges, r4, rect_gap, rects_overlap
from interllm.scene.graph import SceneObject

MAX_FAILS_IN_A_ROW = 250  # object placements failing in a row before the surfaces count as full
EASY_DEPTH = 0.05  # [m] an easy object's box stands at most this far in from the surface margin


class TooFull(SceneGenerationError):
    """Not even half the objects fit: no other attempt will place them all; stop at once."""


def place_object(b: BuildState, category: str, fid: str, mode: str, *, tries: int = 25,
                 accept: Callable[[float, float], bool] | None = None, easy: bool = False) -> str | None:
    """Put one object of ``category`` on furniture ``fid`` with a placement mode; None if no room.

    easy: a front object whose box stands at most EASY_DEPTH [m] in from the surface margin.
    accept(x, y): a further test of the spot's centre [m] (graded design: robot floor within reach).
    """
    pl = b.cat.placement
    oc = b.cat.objects[category]
    drawn = b.assets.object(category, b.rng)  # its size (and asset): scene.assets
    f = b.furniture[fid]
    fx0, fy0, fx1, fy1 = f.footprint
    m = pl.surface_margin
    edges = free_edges(b.rooms[f.room].bounds, f) or ("S", "N", "W", "E")
    existing = [o for o in b.objects.values() if o.furniture == fid]
    if f.surface_height >= pl.high_min:
        mode = "high"
    for _ in range(tries):
        sx, sy = drawn.size[0], drawn.size[1]
        if b.rng.random() < 0.5:
            sx, sy = sy, sx
        if mode in ("front", "high"):
            e = edges[int(b.rng.integers(len(edges)))]
            perp = sy if e in ("S", "N") else sx
            if perp / 2 + m > pl.front_edge_max:
                sx, sy = sy, sx
                perp = sy if e in ("S", "N") else sx
            dmin, dmax = perp / 2 + m, max(perp / 2 + m, pl.front_edge_max)
            if easy:
                dmax = min(dmax, dmin + EASY_DEPTH)
            dist = b.rng.uniform(dmin, dmax)
            if e in ("S", "N"):
                lo, hi = fx0 + sx / 2 + m, fx1 - sx / 2 - m
                if lo > hi:
                    continue
                x = b.rng.uniform(lo, hi)
                y = fy0 + dist if e == "S" else fy1 - dist
            else:
                lo, hi = fy0 + sy / 2 + m, fy1 - sy / 2 - m
                if lo > hi:
                    continue
                y = b.rng.uniform(lo, hi)
                x = fx0 + dist if e == "W" else fx1 - dist
        elif mode == "deep":
            def need(side, half):
                return max(pl.deep_edge_min, half + m) if side in edges else half + m
            lox, hix = fx0 + need("W", sx / 2), fx1 - need("E", sx / 2)
            loy, hiy = fy0 + need("S", sy / 2), fy1 - need("N", sy / 2)
            if lox > hix or loy > hiy:
                continue
            x, y = b.rng.uniform(lox, hix), b.rng.uniform(loy, hiy)
        else:  # clutter: right next to an object already there
            if not existing:
                return None
            o = existing[int(b.rng.integers(len(existing)))]
            gap = b.rng.uniform(pl.object_gap, pl.clutter_gap_max)
            dirn = int(b.rng.integers(4))
            ox, oy = o.position[0], o.position[1]
            if dirn < 2:
                x = ox + (1 if dirn == 0 else -1) * (o.size[0] / 2 + sx / 2 + gap)
                y = oy + b.rng.uniform(-0.03, 0.03)
            else:
                y = oy + (1 if dirn == 2 else -1) * (o.size[1] / 2 + sy / 2 + gap)
                x = ox + b.rng.uniform(-0.03, 0.03)
        x, y = r4(x), r4(y)
        box = (x - sx / 2, y - sy / 2, x + sx / 2, y + sy / 2)
        if box[0] < fx0 + m - 1e-9 or box[2] > fx1 - m + 1e-9 or box[1] < fy0 + m - 1e-9 \
                or box[3] > fy1 - m + 1e-9:
            continue
        if any(rect_gap(box, _obox(o)) < pl.object_gap - 1e-9 for o in existing):
            continue
        if fid in b.keep_clear and rects_overlap(box, b.keep_clear[fid]):
            continue
        if accept is not None and not accept(x, y):
            continue
        oid = b.new_id(category)
        b.objects[oid] = SceneObject(oid, category, fid, (x, y, r4(f.surface_height + drawn.size[2] / 2)),
                                     (r4(sx), r4(sy), r4(drawn.size[2])), oc.usage, mode, asset=drawn.asset)
        return oid
    return None


def _obox(o: SceneObject) -> tuple[float, float, float, float]:
    """The object's footprint (x0, y0, x1, y1) [m]."""
    return (o.position[0] - o.size[0] / 2, o.position[1] - o.size[1] / 2,
            o.position[0] + o.size[0] / 2, o.position[1] + o.size[1] / 2)


def modes_for(b: BuildState, fid: str, category: str) -> list[str]:
    """Hard placement modes a furniture can offer an object of ``category``."""
    pl = b.cat.placement
    f = b.furniture[fid]
    if f.surface_height >= pl.high_min:
        return ["high"]
    modes = []
    edges = free_edges(b.rooms[f.room].bounds, f)
    half = max(b.cat.objects[category].size[:2]) / 2 + pl.surface_margin
    fx0, fy0, fx1, fy1 = f.footprint
    dx = (fx1 - fx0) - sum(max(pl.deep_edge_min, half) if s in edges else half for s in ("W", "E"))
    dy = (fy1 - fy0) - sum(max(pl.deep_edge_min, half) if s in edges else half for s in ("S", "N"))
    if dx >= 0 and dy >= 0:
        modes.append("deep")
    if any(o.furniture == fid for o in b.objects.values()):
        modes.append("clutter")
    return modes


def add_object(b: BuildState, category: str, hosts: list[str]) -> str | None:
    """Place an object of ``category`` on one of ``hosts`` (hard with hard_placement_prob)."""
    hosts = list(hosts)
    pl = b.cat.placement
    while hosts:
        if b.rng.random() < b.cfg.hard_placement_prob:
            offers = {h: modes_for(b, h, category) for h in hosts}
            modes = sorted({m for ms in offers.values() for m in ms})
            if modes:
                mode = modes[int(b.rng.integers(len(modes)))]
                cand = [h for h in hosts if mode in offers[h]]
            else:
                mode, cand = "front", hosts
        else:
            low = [h for h in hosts if b.furniture[h].surface_height < pl.high_min]
            mode, cand = "front", (low or hosts)
        fid = cand[int(b.rng.integers(len(cand)))]
        oid = place_object(b, category, fid, mode)
        if oid is None and mode != "front":
            oid = place_object(b, category, fid, "front")
        if oid is not None:
            return oid
        hosts.remove(fid)
    return None


def place_legacy_objects(b: BuildState) -> dict[str, bool]:
    """The legacy design (module doc); returns {command id: supported} in catalog order."""
    cat, budget = b.cat, b.cfg.n_objects
    K = cat.min_objects_per_command
    cmds = list(cat.paper_commands()) + [c for c in cat.commands if not c.paper]
    targets = {c.id: b.targets(c) for c in cmds}
    fids = list(b.furniture)

    def valid(cmd):
        return [o for o in b.objects.values() if o.category in cmd.categories
                and o.furniture not in targets[cmd.id]]

    supported: dict[str, bool] = {}
    for cmd in cmds:
        if not targets[cmd.id]:
            supported[cmd.id] = False
            if cmd.paper:
                raise Retry(f"no target furniture for paper command {cmd.id!r}")
            continue
        fails = 0
        while len(valid(cmd)) < K and len(b.objects) < budget and fails < 20:
            hosts_of = {c: [f for f in fids if c in cat.furniture[b.furniture[f].category].holds
                            and f not in targets[cmd.id]] for c in cmd.categories}
            cats = [c for c in cmd.categories if hosts_of[c]]
            if not cats:
                break
            open_cmds = [c2 for c2 in cmds if targets[c2.id] and c2.id not in supported]
            w = np.array([1.0 + sum(c in c2.categories for c2 in open_cmds if c2 is not cmd) for c in cats])
            c = cats[int(b.rng.choice(len(cats), p=w / w.sum()))]
            used_rooms = {b.furniture[o.furniture].room for o in valid(cmd)}
            hosts = [h for h in hosts_of[c] if b.furniture[h].room not in used_rooms] or hosts_of[c]
            if add_object(b, c, hosts) is None:
                fails += 1
        supported[cmd.id] = len(valid(cmd)) >= K
        if cmd.paper and not supported[cmd.id]:
            raise Retry(f"paper command {cmd.id!r} has fewer than {K} valid objects")
    fill_budget(b)
    return {c.id: supported[c.id] for c in cat.commands}


def _random_category(b: BuildState, fid: str) -> str:
    """A category furniture ``fid`` holds, drawn uniformly or with ``b.assets``'s weights."""
    f = b.furniture[fid]
    holds = b.cat.furniture[f.category].holds
    w = b.assets.object_weights(f.category, b.rooms[f.room].type, holds)
    if w is None:
        return holds[int(b.rng.integers(len(holds)))]
    return holds[int(b.rng.choice(len(holds), p=w))]


def fill_budget(b: BuildState) -> None:
    """Random objects on random furniture (hard with hard_placement_prob) up to scene.n_objects.
    Full surfaces: ``TooFull`` when not even half the objects fit, else ``Retry``."""
    cat, budget = b.cat, b.cfg.n_objects
    fids = [f for f, fu in b.furniture.items() if cat.furniture[fu.category].holds]  # chairs hold nothing
    fails = in_a_row = 0
    while len(b.objects) < budget:
        fid = fids[int(b.rng.integers(len(fids)))]
        if add_object(b, _random_category(b, fid), [fid]) is None:
            fails += 1
            in_a_row += 1
            # surfaces are full: too many failures in all, or in a row (bounds the work for big budgets)
            if fails > 50 + 5 * budget or in_a_row > MAX_FAILS_IN_A_ROW:
                if 2 * len(b.objects) < budget:
                    raise TooFull(
                        f"scene.n_objects={budget} does not fit: the surfaces of the {len(fids)} furniture "
                        f"(scene.n_furniture) were full after {len(b.objects)} objects; lower scene.n_objects "
                        f"to about {len(b.objects)}, or raise scene.n_furniture to about "
                        f"{-(-budget * len(fids) // max(1, len(b.objects)))}")
                raise Retry(f"could place only {len(b.objects)} of {budget} objects; surfaces are full "
                            "(raise scene.n_furniture or lower scene.n_objects)")
        else:
            in_a_row = 0

