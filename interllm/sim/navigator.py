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
        """Drive to ``action.furniture`` from the current base pose, starting at ``clock`` [s]:
        plan a path on the belief map, follow it, and on a contact learn, back off and plan again."""
        if action.kind != "navigate":
            raise ValueError(f"Navigator.navigate got a {action.kind!r} action: {action}")
        why = _invalid_target(scene, action)
        if why:
            return _fail(action, why)
        cfg = self.cfg
        goal = belief.anchor(action.furniture)
        drive = _Drive.start(cfg, physics, clock)
        presumed = None
        last_hit = ("", "")
        reason = ""
        success = False
        while True:
            path = belief.search.path((drive.x, drive.y), goal)  # plan
            if presumed is None:
                presumed = np.zeros((0, 2)) if path is None else path.copy()
            if path is None:
                where = f" (last at {last_hit[0]} {last_hit[1]})" if drive.collisions else ""
                reason = (f"{action}: no collision-free path to {action.furniture} on the robot's map after "
                          f"{drive.collisions} collisions{where}")
                break
            hit, leg = drive.follow(path)  # step
            if hit is None:
                success = True
                break
            last_hit = drive.recover(hit, leg, belief, self.resolution)  # recover
            if drive.collisions > cfg.max_nav_replans:
                reason = (f"{action}: blocked at {last_hit[0]} {last_hit[1]} after {drive.collisions} collisions "
                          f"(max_nav_replans={cfg.max_nav_replans})")
                break
        return drive.result(action, success, presumed, reason)


def _invalid_target(scene: SceneGraph, action: Action) -> str:
    """Why ``action`` cannot be driven to: an unknown furniture or a wrong room ("" when it can)."""
    if action.furniture not in scene.furniture:
        return f"{action}: unknown furniture {action.furniture!r}; valid furniture: {sorted(scene.furniture)}"
    fur = scene.furniture[action.furniture]
    if action.room is not None and action.room != fur.room:
        return f"{action}: {action.furniture} is in room {fur.room}, not {action.room}"
    return ""


class _Drive:
    """One navigate action as it runs: the base pose x [m], y [m], yaw [rad], what is measured
    (distance [m], 45° turns, collisions), the driven points and the trajectory samples."""

    def __init__(self, cfg: SimConfig, physics: MujocoWorld, t0: float) -> None:
        self.cfg, self.physics, self.t0 = cfg, physics, t0
        self.x, self.y, self.yaw = physics.robot_pose
        self.distance = 0.0
        self.n_turns = 0
        self.collisions = 0
        self.driven: list[tuple[float, float]] = [(self.x, self.y)]
        self.samples: list = []
        self.touching: set[int] = set()

    @classmethod
    def start(cls, cfg: SimConfig, physics: MujocoWorld, t0: float) -> _Drive:
        """Start at the current base pose at ``t0`` [s]. What the base already touches where it
        stands (it was put there, it did not drive into it) is no collision until the base has
        come free of it."""
        drive = cls(cfg, physics, t0)
        drive._put()
        drive.touching = {gid for gid, _, _, _ in physics.base_contacts()}
        return drive

    def now(self) -> float:
        """[s] the mission clock: t0 + the time measured so far."""
        cfg = self.cfg
        return (self.t0 + self.distance / cfg.base_speed + self.n_turns * cfg.turn / cfg.turn_speed
                + self.collisions * cfg.recovery_time)

    def _put(self) -> None:
        """Set the base pose in MuJoCo and take a trajectory sample."""
        self.physics.set_base(self.x, self.y, self.yaw)
        self.physics.forward()
        self.samples.append(self.physics.sample(self.now()))

    def follow(self, path) -> tuple[list | None, list[tuple[float, float]]]:
        """Drive along ``path`` [N, 2] [m]; returns (the new contacts that stopped it, or None at
        the end of the path; the points of this leg, from where it started)."""
        targets = list(path)
        if targets and math.hypot(targets[0][0] - self.x, targets[0][1] - self.y) <= _EPS:
            targets = targets[1:]
        leg: list[tuple[float, float]] = [(self.x, self.y)]
        for wp in targets:
            hit = self._drive_to(float(wp[0]), float(wp[1]), leg)
            if hit:
                return hit, leg
        return None, leg

    def _drive_to(self, wx: float, wy: float, leg: list[tuple[float, float]]) -> list | None:
        """Turn towards (wx, wy) [m] in 45° controls, then move there in ``sim.step`` controls,
        querying contacts after each; returns the new contacts that stopped it, or None."""
        cfg, physics = self.cfg, self.physics
        dx, dy = wx - self.x, wy - self.y
        seg = math.hypot(dx, dy)
        if seg < _EPS:
            return None
        heading = math.atan2(dy, dx)
        dturn = abs(_wrap(heading - self.yaw))
        k = int(math.ceil(dturn / cfg.turn - 1e-6)) if dturn > 1e-6 else 0
        if k:
            self.n_turns += k
            self.yaw = heading
            self._put()
        self.yaw = heading
        nsub = max(1, int(math.ceil(seg / cfg.step - 1e-9)))
        sx, sy = self.x, self.y
        for i in range(1, nsub + 1):
            px, py = sx + dx * i / nsub, sy + dy * i / nsub
            physics.set_base(px, py, self.yaw)
            physics.forward()
            self.distance += seg / nsub
            self.x, self.y = px, py
            self.driven.append((px, py))
            leg.append((px, py))
            contacts = self._new_contacts()
            if contacts:
                return contacts
            self.samples.append(physics.sample(self.now()))
        return None

    def _new_contacts(self) -> list:
        """The base's contacts here, less those it stood against at the start while it is not yet
        free of them."""
        contacts = self.physics.base_contacts()
        if self.touching:
            if not any(c[0] in self.touching for c in contacts):
                self.touching = set()  # free of what it stood against: every contact counts now
            contacts = [c for c in contacts if c[0] not in self.touching]
        return contacts

    def recover(self, hit: list, leg: list[tuple[float, float]], belief: BeliefMap, res: float) -> tuple[str, str]:
        """A collision: count it, block the contact area (and a door leaf's footprint) on the
        belief map, back off ``sim.backoff`` [m] along ``leg``; returns (kind, scene id) of what was
        hit, a door leaf first."""
        cfg, physics = self.cfg, self.physics
        self.collisions += 1
        inflate = cfg.robot_radius + res
        doors = [h for h in hit if h[2] == "door"]
        for gid, pt, kind, _sid in hit:
            belief.block_cells(pt[:2], inflate)
            if kind == "door":
                x0, y0, x1, y1 = physics.geom_footprint(gid)
                belief.block_box(x0 - inflate, y0 - inflate, x1 + inflate, y1 + inflate)
        last_hit = (doors[0][2], doors[0][3]) if doors else (hit[0][2], hit[0][3])
        self.samples.append(physics.sample(self.now()))
        back, _ = _walk_back(leg, cfg.backoff)
        for bx, by in back:
            self.distance += math.hypot(bx - self.x, by - self.y)
            self.x, self.y = bx, by
            self.driven.append((self.x, self.y))
            self._put()
        return last_hit

    def result(self, action: Action, success: bool, presumed, reason: str) -> ActionResult:
        """The navigate result: time t [s] and cost c_nav from what was measured (module doc)."""
        cfg = self.cfg
        time = (self.distance / cfg.base_speed + self.n_turns * cfg.turn / cfg.turn_speed
                + self.collisions * cfg.recovery_time)
        return ActionResult(
            action=action, success=success, cost=nav_cost(self.collisions, time, self.distance, cfg.gamma_nav),
            time=time, collisions=self.collisions, distance=self.distance, presumed_path=presumed,
            driven_path=np.asarray(self.driven, dtype=float), reason=reason,
            trajectory=self.physics.make_trajectory(self.samples))
