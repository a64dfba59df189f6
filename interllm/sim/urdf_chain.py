"""A robot's serial chain read out of a URDF file: the joints from one link to another, with their
frames, axes and limits, as plain data the MuJoCo builder turns into bodies and joints.

A URDF joint's ``<origin xyz rpy>`` is the child link's frame in the parent link's frame (roll,
pitch, yaw about fixed x, y, z: R = Rz(yaw)·Ry(pitch)·Rx(roll)); its ``<axis>`` is in the child
frame, through the child frame's origin. That is MuJoCo's convention for a body's pos/quat and a
joint at ``pos = 0``, so every URDF joint becomes one body (and one joint unless it is fixed).
Only the joint tree is read (no meshes): the chain's kinematics, not its looks.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

KINDS = {"revolute": "hinge", "continuous": "hinge", "prismatic": "slide", "fixed": "fixed"}


@dataclass(frozen=True)
class ChainJoint:
    """One joint of a serial chain. pos [m] and quat (w, x, y, z) place the child frame in the
    parent frame; axis in the child frame; range [rad] or [m] (None: unlimited or fixed)."""

    name: str
    link: str  # the child link (the body this joint moves)
    kind: str  # "hinge" | "slide" | "fixed"
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float]
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    range: tuple[float, float] | None = None


def rpy_quat(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """URDF fixed-axis roll-pitch-yaw [rad] -> quaternion (w, x, y, z) of Rz(yaw)·Ry(pitch)·Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy)


def _floats(text: str | None, n: int = 3, default: float = 0.0) -> tuple[float, ...]:
    vals = [float(v) for v in (text or "").split()]
    return tuple(vals) if len(vals) == n else (default,) * n


def _joint(el: ET.Element) -> ChainJoint:
    kind = KINDS.get(el.get("type", ""))
    if kind is None:
        raise ValueError(f"URDF joint {el.get('name')!r}: type {el.get('type')!r} is not one of {sorted(KINDS)}")
    origin = el.find("origin")
    xyz = _floats(origin.get("xyz") if origin is not None else None)
    rpy = _floats(origin.get("rpy") if origin is not None else None)
    axis_el = el.find("axis")
    axis = _floats(axis_el.get("xyz"), default=0.0) if axis_el is not None else (1.0, 0.0, 0.0)
    limit = el.find("limit")
    rng = None
    if kind != "fixed" and el.get("type") != "continuous" and limit is not None:
        rng = (float(limit.get("lower", 0.0)), float(limit.get("upper", 0.0)))
        if rng[0] == rng[1]:  # a joint that cannot move (e.g. a gripper finger locked open) is fixed
            kind, rng = "fixed", None
    return ChainJoint(name=el.get("name", ""), link=el.find("child").get("link"), kind=kind, pos=xyz, quat=rpy_quat(*rpy), axis=axis, range=rng)


def read_chain(urdf: str | Path, root: str, tip: str) -> list[ChainJoint]:
    """The joints from link ``root`` to link ``tip`` of the URDF file, root first.

    Raises ValueError naming the file and links when ``tip`` does not descend from ``root``."""
    tree = ET.parse(urdf).getroot()
    by_child = {j.find("child").get("link"): j for j in tree.findall("joint")}
    chain, link = [], tip
    while link != root:
        joint = by_child.get(link)
        if joint is None:
            raise ValueError(f"{urdf}: link {tip!r} does not descend from link {root!r} (stopped at {link!r})")
        chain.append(_joint(joint))
        link = joint.find("parent").get("link")
    return chain[::-1]


@dataclass(frozen=True)
class LinkBox:
    """The axis-aligned box around a link's collision mesh, in the link frame: centre and half
    extents [m]."""

    link: str
    centre: tuple[float, float, float]
    half: tuple[float, float, float]


def stl_vertices(path: str | Path) -> np.ndarray:
    """The vertices [N, 3] of a binary STL file (80-byte header, uint32 count, 50 bytes a triangle)."""
    raw = Path(path).read_bytes()
    n = int.from_bytes(raw[80:84], "little")
    if len(raw) != 84 + 50 * n:
        raise ValueError(f"{path}: not a binary STL file ({len(raw)} bytes for {n} triangles)")
    tri = np.frombuffer(raw, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]), count=n,
                        offset=84)
    return tri["v"].reshape(-1, 3).astype(float)


def link_boxes(urdf: str | Path, links: set[str]) -> dict[str, LinkBox]:
    """The collision-mesh box of each link of ``links`` that has one (mesh paths relative to the
    URDF's folder; the mesh's ``<origin>`` and ``scale`` applied; rotated origins are not supported)."""
    urdf = Path(urdf)
    out = {}
    for link in ET.parse(urdf).getroot().findall("link"):
        mesh = link.find("collision/geometry/mesh")
        if link.get("name") not in links or mesh is None:
            continue
        origin = link.find("collision/origin")
        if origin is not None and any(_floats(origin.get("rpy"))):
            raise ValueError(f"{urdf}: link {link.get('name')!r}: a rotated collision origin is not supported")
        shift = np.array(_floats(origin.get("xyz") if origin is not None else None))
        scale = np.array(_floats(mesh.get("scale"), default=1.0))
        v = stl_vertices(urdf.parent / mesh.get("filename", "")) * scale + shift
        lo, hi = v.min(axis=0), v.max(axis=0)
        out[link.get("name")] = LinkBox(link.get("name"), tuple(float(x) for x in (lo + hi) / 2),
                                        tuple(float(x) for x in (hi - lo) / 2))
    return out
