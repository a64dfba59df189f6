"""Execute ``navigate(furniture, room)`` (paper §III low-level controls, §IV-B c_nav).

The robot plans a shortest path on its belief map (``BeliefMap.presumed``: doors presumed open,
plus cells it has learned are blocked) to the furniture's anchor and follows it with the paper's
controls: turn by ``sim.turn`` (45°) and move forward by ``sim.step`` (5 cm). After every move
the base pose is set in MuJoCo and the contacts of the base with walls, door leaves and
furniture are queried (``mj_kinematics`` + ``mj_collision``).

Contacts the base has where the action starts (it was put there, it did not drive into them) do
not count until the base has come free of them. On a contact: ``collisions += 1``, the belief map gets the contact area (a disc of radius
robot_radius + one cell around the contact point) and, for a door leaf, the leaf's footprint
grown by the same amount, as occupied; the robot backs off ``sim.backoff`` [m] along the way it
came and replans. More than ``sim.max_nav_replans`` collisions, or no path left, fail the action
with a reason text.

Measured: distance d [m] (every move, back-offs included), turns n (45° controls), collisions
cc; time t = d / base_speed + n * turn / turn_speed + cc * recovery_time [s];
cost c_nav = γ_nav·cc + t + d. ``presumed_path`` is the first planned path.
"""

from __future__ import annotations

import math

import numpy as np

from interllm.config import SimConfig
from interllm.core.actions import Action
from interllm.core.results import ActionResult, nav_cost
from interllm.scene.graph import SceneGraph
from interllm.sim.belief import BeliefMap
from interllm.sim.physics import MujocoWorld

_EPS = 1e-9


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _fail(action: Action, reason: str) -> ActionResult:
    return ActionResult(action=action, success=False, cost=0.0, time=0.0, reason=reason)


def _walk_back(points: list[tuple[float, float]], length: float) -> tuple[list[tuple[float, float]], float]:
    """Points visited when reversing ``length`` [m] along a polyline from its end; returns the
    points (excluding the current end) and the length actually reversed."""
    out: list[tuple[float, float]] = []
    done = 0.0
    i = len(points) - 1
    cur = points[-1]
    while i > 0 and done < length - _EPS:
        prev = points[i - 1]
        seg = math.hypot(prev[0] - cur[0], prev[1] - cur[1])
        if seg < _EPS:
            i -= 1
            continue
        if done + seg >= length:
            f = (length - done) / seg
            cur = (cur[0] + f * (prev[0] - cur[0]), cur[1] + f * (prev[1] - cur[1]))
            out.append(cur)
            done = length
            break
        done += seg
        cur = prev
        out.append(cur)
        i -= 1
    return out, done


class Navigator:
    """Drives the base to a furniture with the paper's controls (module doc).

    cfg: robot speeds, control steps, collision recovery and γ_nav; resolution: [m] per grid cell.
    """

    def __init__(self, cfg: SimConfig, resolution: float) -> None:
        self.cfg, self.resolution = cfg, float(resolution)

    def navigate(self, physics: MujocoWorld, belief: BeliefMap, scene: SceneGraph, clock: float,
                 action: Action) -> ActionResult:
        """Drive to ``action.furniture`` from the current base pose, starting at ``clock`` [s]."""
        return _drive(self.cfg, self.resolution, physics, belief, scene, clock, action)


def _drive(cfg: SimConfig, res: float, physics: MujocoWorld, belief: BeliefMap, scene: SceneGraph, t0: float,
           action: Action) -> ActionResult:
    if action.kind != "navigate":
        raise ValueError(f"Navigator.navigate got a {action.kind!r} action: {action}")
    if action.furniture not in scene.furniture:
        return _fail(action, f"{action}: unknown furniture {action.furniture!r}; valid furniture: "
                             f"{sorted(scene.furniture)}")
    fur = scene.furniture[action.furniture]
    if action.room is not None and action.room != fur.room:
        return _fail(action, f"{action}: {action.furniture} is in room {fur.room}, not {action.room}")
    goal = belief.anchor(action.furniture)
    x, y, yaw = physics.robot_pose
    distance = 0.0
    n_turns = 0
    collisions = 0
    driven: list[tuple[float, float]] = [(x, y)]
    samples = []

    def now() -> float:
        return t0 + distance / cfg.base_speed + n_turns * cfg.turn / cfg.turn_speed + collisions * cfg.recovery_time

    physics.set_base(x, y, yaw)
    physics.forward()
    samples.append(physics.sample(now()))
    # what the base already touches where it stands (it was put there, it did not drive into it)
    # is no collision until the base has come free of it
    touching = {gid for gid, _, _, _ in physics.base_contacts()}
    presumed = None
    last_hit = ("", "")
    reason = ""
    success = False
    while True:
        path = belief.search.path((x, y), goal)
        if presumed is None:
            presumed = np.zeros((0, 2)) if path is None else path.copy()
        if path is None:
            where = f" (last at {last_hit[0]} {last_hit[1]})" if collisions else ""
            reason = (f"{action}: no collision-free path to {action.furniture} on the robot's map after "
                      f"{collisions} collisions{where}")
            break
        targets = list(path)
        if targets and math.hypot(targets[0][0] - x, targets[0][1] - y) <= _EPS:
            targets = targets[1:]
        leg: list[tuple[float, float]] = [(x, y)]
        hit = None
        for wp in targets:
            wx, wy = float(wp[0]), float(wp[1])
            dx, dy = wx - x, wy - y
            seg = math.hypot(dx, dy)
            if seg < _EPS:
                continue
            heading = math.atan2(dy, dx)
            dturn = abs(_wrap(heading - yaw))
            k = int(math.ceil(dturn / cfg.turn - 1e-6)) if dturn > 1e-6 else 0
            if k:
                n_turns += k
                yaw = heading
                physics.set_base(x, y, yaw)
                physics.forward()
                samples.append(physics.sample(now()))
            yaw = heading
            nsub = max(1, int(math.ceil(seg / cfg.step - 1e-9)))
            sx, sy = x, y
            for i in range(1, nsub + 1):
                px, py = sx + dx * i / nsub, sy + dy * i / nsub
                physics.set_base(px, py, yaw)
                physics.forward()
                distance += seg / nsub
                x, y = px, py
                driven.append((x, y))
                leg.append((x, y))
                contacts = physics.base_contacts()
                if touching:
                    if not any(c[0] in touching for c in contacts):
                        touching = set()  # free of what it stood against: every contact counts now
                    contacts = [c for c in contacts if c[0] not in touching]
                if contacts:
                    hit = contacts
                    break
                samples.append(physics.sample(now()))
            if hit:
                break
        if hit is None:
            success = True
            break
        collisions += 1
        # learn: the contact area (and a door leaf's footprint) is blocked
        inflate = cfg.robot_radius + res
        doors = [h for h in hit if h[2] == "door"]
        for gid, pt, kind, _sid in hit:
            belief.block_cells(pt[:2], inflate)
            if kind == "door":
                x0, y0, x1, y1 = physics.geom_footprint(gid)
                belief.block_box(x0 - inflate, y0 - inflate, x1 + inflate, y1 + inflate)
        last_hit = (doors[0][2], doors[0][3]) if doors else (hit[0][2], hit[0][3])
        samples.append(physics.sample(now()))
        back, done = _walk_back(leg, cfg.backoff)
        for bx, by in back:
            distance += math.hypot(bx - x, by - y)
            x, y = bx, by
            driven.append((x, y))
            physics.set_base(x, y, yaw)
            physics.forward()
            samples.append(physics.sample(now()))
        if collisions > cfg.max_nav_replans:
            reason = (f"{action}: blocked at {last_hit[0]} {last_hit[1]} after {collisions} collisions "
                      f"(max_nav_replans={cfg.max_nav_replans})")
            break
    time = distance / cfg.base_speed + n_turns * cfg.turn / cfg.turn_speed + collisions * cfg.recovery_time
    return ActionResult(
        action=action, success=success, cost=nav_cost(collisions, time, distance, cfg.gamma_nav), time=time,
        collisions=collisions, distance=distance, presumed_path=presumed,
        driven_path=np.asarray(driven, dtype=float), reason=reason,
        trajectory=physics.make_trajectory(samples))
