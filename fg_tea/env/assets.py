"""Assets: what do the mug, kettle, teabag, milk, sugar, drone and house boxes look like in PyBullet?

This module answers what the task objects look like: mug, kettle and teabag resolve to visually
distinct bodies (docs/design.md §8.1); the milk carton and the
sugar jar of the ``make_tea_milk_sugar`` task follow the same rules, in colours none of the
other objects use. Every shape is built at
run time from PyBullet primitives with ``createVisualShape`` / ``createMultiBody``; the mug uses the
``objects/mug.obj`` mesh that ships inside the installed ``pybullet_data`` package when present and
falls back to a cylinder with a handle. Nothing is downloaded.

Bodies are purely kinematic (mass 0, no collision shapes): the environment moves them with
``resetBasePositionAndOrientation``. Each object's origin is the centre of its bottom face, so an
object stands on a surface when its origin is at the surface height. The drone's origin is the
centre of its body. Sizes are metres; colours are RGBA in [0, 1].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

from fg_tea.env.pybullet_quiet import pybullet

Vec3 = tuple[float, float, float]
RGBA = tuple[float, float, float, float]

MUG_COLOR: RGBA = (0.16, 0.42, 0.92, 1.0)
KETTLE_COLOR: RGBA = (0.85, 0.13, 0.10, 1.0)
STEEL: RGBA = (0.78, 0.79, 0.82, 1.0)
BLACK: RGBA = (0.08, 0.08, 0.09, 1.0)
POUCH: RGBA = (0.95, 0.88, 0.70, 1.0)
TAG: RGBA = (0.15, 0.78, 0.30, 1.0)
MILK_WHITE: RGBA = (0.97, 0.97, 0.98, 1.0)
MILK_CAP: RGBA = (0.58, 0.22, 0.78, 1.0)
SUGAR_JAR: RGBA = (0.05, 0.62, 0.60, 1.0)
SUGAR_LID: RGBA = (0.02, 0.42, 0.40, 1.0)
ROTOR: RGBA = (1.0, 0.55, 0.08, 1.0)
DRONE_BODY: RGBA = (0.18, 0.20, 0.24, 1.0)

#: Horizontal radius (m) of the drone's footprint; must not exceed ``EnvConfig.agent_radius``.
DRONE_RADIUS_M = 0.17
#: Forward offset (m) of the egocentric camera from the drone's centre: ahead of every drone part,
#: so the drone never appears in (or occludes) its own camera.
CAMERA_FORWARD_M = 0.20


@dataclass(frozen=True)
class Part:
    """One primitive of a compound visual body.

    Args:
        kind: ``box`` (dims = half extents x, y, z), ``cylinder`` (dims = radius, length),
            ``sphere`` (dims = radius,) or ``mesh`` (dims = scale; `mesh` names the file).
        dims: sizes in metres, as above.
        rgba: colour.
        pos: offset of the part's centre from the body origin (m).
        rpy: roll, pitch, yaw of the part (rad).
        mesh: mesh file for ``kind == "mesh"``.
    """

    kind: str
    dims: tuple[float, ...]
    rgba: RGBA
    pos: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)
    mesh: str = ""


def _kind_id(kind: str) -> int:
    try:
        return {"box": pybullet.GEOM_BOX, "cylinder": pybullet.GEOM_CYLINDER,
                "sphere": pybullet.GEOM_SPHERE, "mesh": pybullet.GEOM_MESH}[kind]
    except KeyError:
        raise ValueError(f"unknown part kind {kind!r}") from None


def _shape_args(part: Part) -> dict:
    if part.kind == "box":
        return {"halfExtents": list(part.dims)}
    if part.kind == "cylinder":
        return {"radius": part.dims[0], "length": part.dims[1]}
    if part.kind == "sphere":
        return {"radius": part.dims[0]}
    return {"fileName": part.mesh, "meshScale": list(part.dims)}


def _visual(client: int, part: Part, in_frame: bool) -> int:
    """Visual shape of `part`; with `in_frame` its offset is baked into the visual frame."""
    frame = {}
    if in_frame:
        frame = {"visualFramePosition": list(part.pos),
                 "visualFrameOrientation": pybullet.getQuaternionFromEuler(part.rpy)}
    return pybullet.createVisualShape(_kind_id(part.kind), rgbaColor=list(part.rgba), physicsClientId=client,
                                      **_shape_args(part), **frame)


def create_compound(client: int, parts: Sequence[Part], position: Vec3 = (0.0, 0.0, 0.0)) -> int:
    """Create one kinematic body from primitives: the first is the base, the rest fixed links.

    Returns:
        The body's unique id (segmentation images report it for every part).
    """
    base, links = parts[0], list(parts[1:])
    n = len(links)
    return pybullet.createMultiBody(
        baseMass=0.0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=_visual(client, base, True),
        basePosition=list(position), baseOrientation=[0, 0, 0, 1],
        linkMasses=[0.0] * n, linkCollisionShapeIndices=[-1] * n,
        linkVisualShapeIndices=[_visual(client, p, False) for p in links],
        linkPositions=[list(p.pos) for p in links],
        linkOrientations=[pybullet.getQuaternionFromEuler(p.rpy) for p in links],
        linkInertialFramePositions=[[0, 0, 0]] * n, linkInertialFrameOrientations=[[0, 0, 0, 1]] * n,
        linkParentIndices=[0] * n, linkJointTypes=[pybullet.JOINT_FIXED] * n,
        linkJointAxis=[[0, 0, 1]] * n, physicsClientId=client,
    )


def box(client: int, center: Vec3, half: Vec3, rgba: RGBA, yaw: float = 0.0) -> int:
    """A static box body (walls, furniture, floor, test occluders). `yaw` in radians."""
    visual = pybullet.createVisualShape(pybullet.GEOM_BOX, halfExtents=list(half), rgbaColor=list(rgba),
                                        physicsClientId=client)
    return pybullet.createMultiBody(baseMass=0.0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=visual,
                                    basePosition=list(center),
                                    baseOrientation=pybullet.getQuaternionFromEuler((0.0, 0.0, yaw)),
                                    physicsClientId=client)


def _mug_mesh() -> str | None:
    try:
        import pybullet_data
    except ImportError:
        return None
    path = Path(pybullet_data.getDataPath()) / "objects" / "mug.obj"
    return str(path) if path.is_file() else None


def mug_parts() -> list[Part]:
    """A blue mug, 0.10 m tall, 0.082 m across, handle along -x.

    Uses pybullet_data's mug mesh (origin at the bottom centre) if installed, else a cylinder
    with a box handle.
    """
    mesh = _mug_mesh()
    if mesh is not None:
        return [Part("mesh", (1.0, 1.0, 1.0), MUG_COLOR, rpy=(0.0, 0.0, math.pi / 2), mesh=mesh)]
    return [Part("cylinder", (0.041, 0.10), MUG_COLOR, pos=(0.0, 0.0, 0.05)),
            Part("box", (0.006, 0.02, 0.03), MUG_COLOR, pos=(0.0, 0.058, 0.05))]


def kettle_parts() -> list[Part]:
    """A red kettle about 0.22 m tall: body, steel lid and knob, spout (+x) and black handle (-x)."""
    return [
        Part("cylinder", (0.085, 0.15), KETTLE_COLOR, pos=(0.0, 0.0, 0.075)),
        Part("cylinder", (0.087, 0.012), STEEL, pos=(0.0, 0.0, 0.006)),
        Part("cylinder", (0.065, 0.02), STEEL, pos=(0.0, 0.0, 0.16)),
        Part("sphere", (0.018,), BLACK, pos=(0.0, 0.0, 0.178)),
        Part("cylinder", (0.016, 0.11), KETTLE_COLOR, pos=(0.115, 0.0, 0.11), rpy=(0.0, math.radians(55), 0.0)),
        Part("box", (0.012, 0.016, 0.055), BLACK, pos=(-0.115, 0.0, 0.12)),
        Part("box", (0.05, 0.016, 0.012), BLACK, pos=(-0.08, 0.0, 0.185)),
        Part("box", (0.03, 0.016, 0.01), BLACK, pos=(-0.095, 0.0, 0.065)),
    ]


def teabag_parts() -> list[Part]:
    """A teabag: a 0.08 x 0.07 x 0.03 m pouch, a string and a green tag standing above it."""
    return [
        Part("box", (0.04, 0.035, 0.015), POUCH, pos=(0.0, 0.0, 0.015)),
        Part("box", (0.041, 0.006, 0.016), (0.86, 0.78, 0.58, 1.0), pos=(0.0, 0.0, 0.016)),
        Part("cylinder", (0.0025, 0.09), (0.96, 0.96, 0.96, 1.0), pos=(0.0, 0.0, 0.075)),
        Part("box", (0.022, 0.003, 0.018), TAG, pos=(0.0, 0.0, 0.13)),
    ]


def milk_parts() -> list[Part]:
    """A 1 l milk carton: a white 0.07 x 0.07 x 0.17 m box under a gabled top, 0.20 m tall in all.

    The gable is two white slopes meeting at a ridge; a purple band round the box and a purple
    screw cap on the front (+x) slope tell it apart from the cream teabag pouch.
    """
    slope = math.radians(35)
    return [
        Part("box", (0.035, 0.035, 0.085), MILK_WHITE, pos=(0.0, 0.0, 0.085)),
        Part("box", (0.0355, 0.0355, 0.03), MILK_CAP, pos=(0.0, 0.0, 0.105)),
        Part("box", (0.021, 0.035, 0.004), MILK_WHITE, pos=(0.017, 0.0, 0.182), rpy=(0.0, slope, 0.0)),
        Part("box", (0.021, 0.035, 0.004), MILK_WHITE, pos=(-0.017, 0.0, 0.182), rpy=(0.0, -slope, 0.0)),
        Part("box", (0.004, 0.035, 0.01), MILK_WHITE, pos=(0.0, 0.0, 0.192)),
        Part("cylinder", (0.013, 0.014), MILK_CAP, pos=(0.022, 0.0, 0.188), rpy=(0.0, slope, 0.0)),
    ]


def sugar_parts() -> list[Part]:
    """A sugar jar 0.08 m across and 0.08 m tall: a teal body, a darker lid and a white knob."""
    return [
        Part("cylinder", (0.04, 0.062), SUGAR_JAR, pos=(0.0, 0.0, 0.031)),
        Part("cylinder", (0.042, 0.01), SUGAR_LID, pos=(0.0, 0.0, 0.067)),
        Part("sphere", (0.009,), MILK_WHITE, pos=(0.0, 0.0, 0.074)),
    ]


def drone_parts() -> list[Part]:
    """A small quadrotor, origin at its body centre, nose along +x.

    A dark body with a camera pod at the nose, two crossed arms, four orange rotors and two
    skids; radius DRONE_RADIUS_M. A red nose marks its heading in third-person views.
    """
    arm = 0.085
    parts = [
        Part("box", (0.07, 0.055, 0.028), DRONE_BODY),
        Part("box", (0.018, 0.03, 0.018), BLACK, pos=(0.078, 0.0, -0.006)),
        Part("sphere", (0.014,), (0.9, 0.1, 0.1, 1.0), pos=(0.07, 0.0, 0.026)),
        Part("box", (0.13, 0.009, 0.008), DRONE_BODY, pos=(0.0, 0.0, 0.018), rpy=(0.0, 0.0, math.radians(45))),
        Part("box", (0.13, 0.009, 0.008), DRONE_BODY, pos=(0.0, 0.0, 0.018), rpy=(0.0, 0.0, math.radians(-45))),
        Part("box", (0.05, 0.006, 0.004), BLACK, pos=(0.0, 0.045, -0.045)),
        Part("box", (0.05, 0.006, 0.004), BLACK, pos=(0.0, -0.045, -0.045)),
        Part("box", (0.004, 0.004, 0.012), BLACK, pos=(0.0, 0.045, -0.035)),
        Part("box", (0.004, 0.004, 0.012), BLACK, pos=(0.0, -0.045, -0.035)),
    ]
    for sx in (-1, 1):
        for sy in (-1, 1):
            parts.append(Part("cylinder", (0.06, 0.006), ROTOR, pos=(sx * arm, sy * arm, 0.032)))
            parts.append(Part("cylinder", (0.008, 0.02), BLACK, pos=(sx * arm, sy * arm, 0.022)))
    return parts


#: Asset name (ObjectSpec.asset or category) -> parts factory.
OBJECT_ASSETS: dict[str, Callable[[], list[Part]]] = {
    "mug": mug_parts,
    "kettle": kettle_parts,
    "teabag": teabag_parts,
    "milk": milk_parts,
    "sugar": sugar_parts,
}


def object_parts(asset: str, category: str) -> list[Part]:
    """Parts for an object asset; an unknown asset falls back to its category, then to a grey box."""
    for key in (asset, category):
        if key in OBJECT_ASSETS:
            return OBJECT_ASSETS[key]()
    return [Part("box", (0.05, 0.05, 0.05), (0.6, 0.6, 0.6, 1.0), pos=(0.0, 0.0, 0.05))]


def _mesh_radius(path: str, scale: Sequence[float]) -> tuple[Vec3, Vec3]:
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    with open(path) as fh:
        for line in fh:
            if line.startswith("v "):
                xyz = [float(v) * s for v, s in zip(line.split()[1:4], scale)]
                lo = [min(a, b) for a, b in zip(lo, xyz)]
                hi = [max(a, b) for a, b in zip(hi, xyz)]
    return (lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])


def local_bounds(parts: Sequence[Part]) -> tuple[Vec3, Vec3]:
    """A conservative axis-aligned box (min, max corners, m) around all parts, in the body frame.

    Each primitive is bounded by the sphere around its centre (so any rotation is covered);
    meshes by the box of their vertices.
    """
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    for part in parts:
        if part.kind == "mesh":
            mlo, mhi = _mesh_radius(part.mesh, part.dims)
            r = max(math.hypot(*mlo), math.hypot(*mhi))
            plo = [part.pos[i] + (mlo[i] if part.rpy == (0.0, 0.0, 0.0) else -r) for i in range(3)]
            phi = [part.pos[i] + (mhi[i] if part.rpy == (0.0, 0.0, 0.0) else r) for i in range(3)]
        else:
            if part.kind == "box":
                r = math.sqrt(sum(d * d for d in part.dims))
            elif part.kind == "cylinder":
                r = math.hypot(part.dims[0], part.dims[1] / 2)
            else:
                r = part.dims[0]
            plo = [c - r for c in part.pos]
            phi = [c + r for c in part.pos]
        lo = [min(a, b) for a, b in zip(lo, plo)]
        hi = [max(a, b) for a, b in zip(hi, phi)]
    return (lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])
