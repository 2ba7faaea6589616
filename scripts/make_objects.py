"""Writes the shipped object set, `assets/objects/*.obj` (+ one `objects.mtl`), from the
shapes defined here: everyday objects a Panda can pick up, made for this project (no
downloads). Each is one closed triangle mesh in metres, its base on z = 0 and centred on the
z axis, built from profiles turned about z (can, bottle, bowl, mug, ...) or tubes swept along
a curve (the banana, the mug's handle). The output is deterministic: running the script
again writes the same bytes, which `tests/python/test_object_assets.py` checks.

    python scripts/make_objects.py [--out assets/objects]

Objects become collision shapes through `MeshFile` (a convex decomposition, cached);
`assets/objects/README.md` lists them with their sizes and the licence.
"""

from __future__ import annotations

import argparse
import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# Colours (diffuse, linear RGB) by material name; written to objects.mtl.
MATERIALS = {
    "red": (0.75, 0.12, 0.10),
    "green": (0.15, 0.55, 0.20),
    "blue": (0.15, 0.30, 0.75),
    "yellow": (0.90, 0.75, 0.15),
    "white": (0.85, 0.85, 0.82),
    "orange": (0.90, 0.45, 0.10),
    "brown": (0.45, 0.28, 0.15),
    "grey": (0.45, 0.47, 0.50),
    "purple": (0.45, 0.20, 0.55),
    "teal": (0.10, 0.50, 0.50),
}


@dataclass
class Mesh:
    """Vertices (n x 3) and triangles (m x 3, counter-clockwise seen from outside)."""

    vertices: list[np.ndarray] = field(default_factory=list)
    triangles: list[tuple[int, int, int]] = field(default_factory=list)

    def add(self, points: np.ndarray) -> int:
        """Appends points; returns the index of the first."""
        first = sum(len(v) for v in self.vertices)
        self.vertices.append(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        return first

    def extend(self, other: Mesh) -> None:
        offset = sum(len(v) for v in self.vertices)
        self.vertices.extend(other.vertices)
        self.triangles.extend((a + offset, b + offset, c + offset) for a, b, c in other.triangles)

    def points(self) -> np.ndarray:
        return np.concatenate(self.vertices)


def band(mesh: Mesh, a: int, b: int, segments: int) -> None:
    """Joins the ring of `segments` points starting at index `a` to the next one at `b` with
    two triangles per side, facing out for rings in the same winding."""
    for k in range(segments):
        k1 = (k + 1) % segments
        mesh.triangles.append((a + k, a + k1, b + k1))
        mesh.triangles.append((a + k, b + k1, b + k))


def lathe(profile: list[tuple[float, float]], segments: int, closed: bool = True) -> Mesh:
    """The surface turned about z from a profile of (radius, z) points, in order from the
    bottom centre up the outside (and back down the inside for a hollow object). A radius of 0
    at either end closes the surface there with a single pole."""
    mesh = Mesh()
    rings = []
    angles = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    for r, z in profile:
        if r == 0.0:
            rings.append(("pole", mesh.add([[0.0, 0.0, z]])))
        else:
            ring = np.stack([r * np.cos(angles), r * np.sin(angles), np.full(segments, z)], 1)
            rings.append(("ring", mesh.add(ring)))
    for (kind0, a), (kind1, b) in itertools.pairwise(rings):
        if kind0 == "ring" and kind1 == "ring":
            band(mesh, a, b, segments)
            continue
        for k in range(segments):
            k1 = (k + 1) % segments
            if kind0 == "pole" and kind1 == "ring":
                mesh.triangles.append((a, b + k1, b + k))
            elif kind0 == "ring" and kind1 == "pole":
                mesh.triangles.append((a + k, a + k1, b))
    if closed and rings[0][0] == "ring" and rings[-1][0] == "ring":
        # Join the last ring to the first (a hollow profile that ends where it started).
        band(mesh, rings[-1][1], rings[0][1], segments)
    return closed_and_outward(mesh)


def tube_rings(
    centres: np.ndarray, radii: np.ndarray, segments: int, up: np.ndarray, phase: float = 0.0
) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """The cross-sections of a tube swept along a curve of centres (n x 3) with a radius per
    centre (`up` fixes their roll), and the tips of its two rounded ends."""
    tangents = np.gradient(centres, axis=0)
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    angles = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False) + phase
    rings = []
    for i in range(len(centres)):
        side = np.cross(tangents[i], up)
        side /= np.linalg.norm(side)
        normal = np.cross(side, tangents[i])
        rings.append(
            centres[i]
            + radii[i] * (np.cos(angles)[:, None] * side + np.sin(angles)[:, None] * normal)
        )
    start = centres[0] - tangents[0] * radii[0] * 0.5
    end = centres[-1] + tangents[-1] * radii[-1] * 0.5
    return rings, start, end


def closed_tube(rings: list[np.ndarray], start: np.ndarray, end: np.ndarray) -> Mesh:
    """The closed surface through cross-sections, capped by the points `start` and `end`."""
    mesh = Mesh()
    segments = len(rings[0])
    first = mesh.add([start])
    ids = [mesh.add(ring) for ring in rings]
    last = mesh.add([end])
    for k in range(segments):
        k1 = (k + 1) % segments
        mesh.triangles.append((first, ids[0] + k1, ids[0] + k))
        mesh.triangles.append((ids[-1] + k, ids[-1] + k1, last))
    for a, b in itertools.pairwise(ids):
        band(mesh, a, b, segments)
    return closed_and_outward(mesh)


def tube(
    centres: np.ndarray, radii: np.ndarray, segments: int, up: np.ndarray, phase: float = 0.0
) -> Mesh:
    """A tube swept along a curve of centres (n x 3) with a radius per centre, closed at both
    ends by points half a radius out; `up` fixes the roll of its cross-sections."""
    return closed_tube(*tube_rings(centres, radii, segments, up, phase))


def closed_and_outward(mesh: Mesh) -> Mesh:
    """Checks that every edge is shared by exactly two triangles in opposite directions (a
    closed, consistently oriented surface) and turns the triangles outward (a positive
    enclosed volume)."""
    edges: dict[tuple[int, int], int] = {}
    for a, b, c in mesh.triangles:
        for e in ((a, b), (b, c), (c, a)):
            edges[e] = edges.get(e, 0) + 1
    for (a, b), n in edges.items():
        assert n == 1 and edges.get((b, a)) == 1, f"edge {a}-{b} is not shared once each way"
    p = mesh.points()
    volume = sum(np.dot(p[a], np.cross(p[b], p[c])) for a, b, c in mesh.triangles) / 6.0
    if volume < 0:
        mesh.triangles = [(a, c, b) for a, b, c in mesh.triangles]
    return mesh


def box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> Mesh:
    mesh = Mesh()
    corners = [
        [hi[0] if k & 1 else lo[0], hi[1] if k & 2 else lo[1], hi[2] if k & 4 else lo[2]]
        for k in range(8)
    ]
    mesh.add(corners)
    for a, b, c, d in [
        (0, 2, 3, 1),
        (4, 5, 7, 6),
        (0, 1, 5, 4),
        (2, 6, 7, 3),
        (0, 4, 6, 2),
        (1, 3, 7, 5),
    ]:
        mesh.triangles += [(a, b, c), (a, c, d)]
    return closed_and_outward(mesh)


Parts = list[Mesh] | None


def solid_lathe(profile: list[tuple[float, float]], segments: int) -> tuple[Mesh, Parts]:
    """A solid turned about z (the profile runs from the axis at the bottom, up the outside,
    back to the axis at the top) and its exact convex decomposition: one frustum (or cone,
    where the profile meets the axis) per profile segment that rises."""

    def piece(r0: float, z0: float, r1: float, z1: float) -> Mesh:
        corners = [(0.0, z0), (r0, z0), (r1, z1), (0.0, z1)]
        return lathe([c for k, c in enumerate(corners) if k in (0, 3) or c[0] > 0], segments)

    parts = [
        piece(r0, z0, r1, z1)
        for (r0, z0), (r1, z1) in itertools.pairwise(profile)
        if z1 > z0 and max(r0, r1) > 0
    ]
    return lathe(profile, segments), parts


def solid_tube(
    centres: np.ndarray, radii: np.ndarray, segments: int, up: np.ndarray, phase: float = 0.0
) -> tuple[Mesh, Parts]:
    """A tube ([`tube`]) and its exact convex decomposition: one piece per pair of successive
    cross-sections (flat where it meets the next, rounded at the tube's ends)."""
    rings, start, end = tube_rings(centres, radii, segments, up, phase)
    parts = []
    for i in range(len(rings) - 1):
        a = start if i == 0 else rings[i].mean(0)
        b = end if i == len(rings) - 2 else rings[i + 1].mean(0)
        parts.append(closed_tube(rings[i : i + 2], a, b))
    return closed_tube(rings, start, end), parts


def hollow(
    outer: list[tuple[float, float]], wall: float, bottom: float
) -> list[tuple[float, float]]:
    """A cup-like profile: the outer profile from the bottom centre up to the rim, then down
    the inside `wall` inwards to a floor `bottom` above the base, ending at the centre."""
    rim_r, rim_z = outer[-1]
    inside = [(r - wall, z) for r, z in reversed(outer[1:]) if z >= bottom and r - wall > 0]
    return [*outer, (rim_r - wall, rim_z), *inside[1:], (outer[1][0] - wall, bottom), (0.0, bottom)]


def can() -> tuple[Mesh, Parts]:
    return solid_lathe(
        [(0.0, 0.0), (0.030, 0.0), (0.033, 0.004), (0.033, 0.116), (0.029, 0.122), (0.0, 0.122)], 24
    )


def bottle() -> tuple[Mesh, Parts]:
    # A straight neck under a wider cap: fingers closing on the neck meet it along their whole
    # pads (on a tapered neck they would touch its widest ring only, and the bottle would swing
    # about it).
    profile = [(0.0, 0.0), (0.030, 0.0), (0.032, 0.005), (0.032, 0.130), (0.026, 0.155)]
    profile += [(0.014, 0.175), (0.014, 0.205), (0.0165, 0.207), (0.0165, 0.225), (0.0, 0.225)]
    return solid_lathe(profile, 20)


def bowl() -> tuple[Mesh, Parts]:
    outer = [(0.0, 0.0), (0.035, 0.0), (0.040, 0.006)]
    outer += [
        (0.040 + 0.030 * math.sin(t), 0.006 + 0.044 * (1 - math.cos(t)))
        for t in np.linspace(0.2, math.pi / 2, 6)
    ]
    # Hollow: its collision shape is the V-HACD decomposition of the mesh.
    return lathe(hollow(outer, 0.006, 0.008), 24), None


def mug() -> tuple[Mesh, Parts]:
    body = lathe(hollow([(0.0, 0.0), (0.032, 0.0), (0.033, 0.095)], 0.005, 0.008), 24)
    # The handle: a half ring from the wall, outside on +x.
    t = np.linspace(-math.pi / 2, math.pi / 2, 9)
    centres = np.stack([0.030 + 0.028 * np.cos(t), np.zeros_like(t), 0.048 + 0.030 * np.sin(t)], 1)
    body.extend(tube(centres, np.full(len(t), 0.007), 10, np.array([0.0, 1.0, 0.0])))
    return body, None


def banana() -> tuple[Mesh, Parts]:
    # An arc of radius 11 cm in the x-y plane, thickest (1.8 cm radius) in the middle and
    # tapered to the ends, lying on the floor along its whole length (so it rests as made).
    t = np.linspace(-0.9, 0.9, 13)
    thickness = 0.018 * np.sqrt(np.clip(1 - t**2, 0.05, 1.0))
    centres = np.stack([0.11 * np.sin(t), 0.11 * (1 - np.cos(t)), thickness], 1)
    centres[:, 1] -= 0.5 * (centres[:, 1].min() + centres[:, 1].max())
    return solid_tube(centres, thickness, 12, np.array([0.0, 0.0, 1.0]))


def tennis_ball() -> tuple[Mesh, Parts]:
    r = 0.033
    profile = [(r * math.sin(a), r - r * math.cos(a)) for a in np.linspace(0.0, math.pi, 11)]
    profile[0] = (0.0, 0.0)
    profile[-1] = (0.0, 2 * r)
    return solid_lathe(profile, 20)


def block() -> tuple[Mesh, Parts]:
    block = box((-0.025, -0.04, 0.0), (0.025, 0.04, 0.05))
    return block, [block]


def hammer() -> tuple[Mesh, Parts]:
    # A T: a handle along x lying on the floor, a head across it at one end.
    parts = [
        box((-0.09, -0.012, 0.0), (0.06, 0.012, 0.024)),
        box((0.06, -0.045, 0.0), (0.09, 0.045, 0.03)),
    ]
    whole = Mesh()
    for part in parts:
        whole.extend(part)
    return whole, parts


def screwdriver() -> tuple[Mesh, Parts]:
    # Lying on the floor along x: a handle (radius 1.4 cm, 10 cm; 16 sides, one of them flat on
    # the floor) and a thin shaft (3 mm, 8 cm) on the same axis; 18 cm from end to end,
    # centred on the z axis.
    axis = np.array([0.0, 0.0, 1.0])
    half_step = math.pi / 16
    height = 0.014 * math.cos(half_step)
    handle = np.stack([np.linspace(-0.08725, 0.01275, 6), np.zeros(6), np.full(6, height)], 1)
    body, parts = solid_tube(handle, np.full(6, 0.014), 16, axis, phase=half_step)
    shaft = np.stack([np.linspace(0.01275, 0.09275, 5), np.zeros(5), np.full(5, height)], 1)
    shaft_mesh, shaft_parts = solid_tube(shaft, np.full(5, 0.003), 8, axis)
    body.extend(shaft_mesh)
    return body, parts + shaft_parts


def pear() -> tuple[Mesh, Parts]:
    # A round body (radius 3 cm, widest 3 cm up) on a flat base 4 cm across (it stands), under
    # a neck narrowing to the top at 8.2 cm.
    profile = [(0.0, 0.0), (0.02, 0.0)]
    angles = [math.asin(0.02 / 0.03), *np.linspace(0.5, 2.2, 8)[2:]]
    profile += [(0.03 * math.sin(a), 0.03 - 0.03 * math.cos(a)) for a in angles]
    profile += [(0.019, 0.060), (0.014, 0.072), (0.008, 0.080), (0.0, 0.082)]
    return solid_lathe(profile, 20)


# name: (builder, material)
OBJECTS = {
    "can": (can, "red"),
    "bottle": (bottle, "green"),
    "bowl": (bowl, "blue"),
    "mug": (mug, "white"),
    "banana": (banana, "yellow"),
    "tennis_ball": (tennis_ball, "yellow"),
    "block": (block, "orange"),
    "hammer": (hammer, "brown"),
    "screwdriver": (screwdriver, "purple"),
    "pear": (pear, "teal"),
}


def write_obj(path: Path, name: str, mesh: Mesh, material: str) -> None:
    points = mesh.points()
    lines = [
        f"# {name}: made by scripts/make_objects.py (panda_rapier); metres, base on z = 0",
        "mtllib objects.mtl",
        f"o {name}",
        f"usemtl {material}",
    ]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in points]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in mesh.triangles]
    path.write_text("\n".join(lines) + "\n")


def write_parts(path: Path, name: str, parts: list[Mesh]) -> None:
    """The convex decomposition: one `o` block per convex part (as PyBullet's `_vhacd` files
    hold theirs), read with `MeshCollision::Parts`."""
    lines = [
        f"# {name}: convex collision parts, made by scripts/make_objects.py (panda_rapier)",
    ]
    first = 1
    for k, part in enumerate(parts):
        points = part.points()
        lines.append(f"o part_{k}")
        lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in points]
        lines += [f"f {a + first} {b + first} {c + first}" for a, b, c in part.triangles]
        first += len(points)
    path.write_text("\n".join(lines) + "\n")


def write_mtl(path: Path) -> None:
    lines = ["# Colours of the shipped objects: made by scripts/make_objects.py (panda_rapier)"]
    for name, (r, g, b) in MATERIALS.items():
        lines += [f"newmtl {name}", f"Kd {r:.3f} {g:.3f} {b:.3f}", ""]
    path.write_text("\n".join(lines))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--out", type=Path, default=Path(__file__).parent.parent / "assets" / "objects"
    )
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    write_mtl(args.out / "objects.mtl")
    for name, (builder, material) in OBJECTS.items():
        mesh, parts = builder()
        write_obj(args.out / f"{name}.obj", name, mesh, material)
        if parts is not None:
            write_parts(args.out / f"{name}_collision.obj", name, parts)
        lo, hi = mesh.points().min(0), mesh.points().max(0)
        size = " x ".join(f"{100 * s:.1f}" for s in hi - lo)
        collision = f"{len(parts)} convex parts" if parts is not None else "decomposed when loaded"
        print(
            f"{name:12s} {size} cm, {len(mesh.points())} vertices, {len(mesh.triangles)} "
            f"triangles; collision: {collision}"
        )


if __name__ == "__main__":
    main()
