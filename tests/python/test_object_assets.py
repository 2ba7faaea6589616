"""The shipped object set (`assets/objects`) is what `scripts/make_objects.py` makes, and the
cabinet (`assets/cabinet`) what `scripts/make_cabinet.py` makes: each script, run again, writes
the same bytes; every mesh is closed and turned outward."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
ASSETS = REPO / "assets" / "objects"


def test_the_script_makes_exactly_the_shipped_files(tmp_path: Path) -> None:
    subprocess.run(
        [sys.executable, str(REPO / "scripts" / "make_objects.py"), "--out", str(tmp_path)],
        check=True,
        capture_output=True,
    )
    made = sorted(p.name for p in tmp_path.iterdir())
    shipped = sorted(p.name for p in ASSETS.iterdir() if p.suffix in (".obj", ".mtl"))
    assert made == shipped
    assert len([n for n in made if n.endswith(".obj")]) >= 10
    for name in made:
        assert (tmp_path / name).read_bytes() == (ASSETS / name).read_bytes(), name


def test_the_cabinet_script_makes_exactly_the_shipped_cabinet(tmp_path: Path) -> None:
    subprocess.run(
        [sys.executable, str(REPO / "scripts" / "make_cabinet.py"), "--out", str(tmp_path)],
        check=True,
        capture_output=True,
    )
    shipped = REPO / "assets" / "cabinet"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in shipped.iterdir())
    for path in tmp_path.iterdir():
        assert path.read_bytes() == (shipped / path.name).read_bytes(), path.name


def test_every_object_is_a_closed_outward_mesh_on_the_floor() -> None:
    for path in sorted(ASSETS.glob("*.obj")):
        vertices, triangles = [], []
        for line in path.read_text().splitlines():
            if line.startswith("v "):
                vertices.append([float(c) for c in line.split()[1:]])
            elif line.startswith("f "):
                triangles.append([int(i) - 1 for i in line.split()[1:]])
        edges: dict[tuple[int, int], int] = {}
        for a, b, c in triangles:
            for edge in ((a, b), (b, c), (c, a)):
                edges[edge] = edges.get(edge, 0) + 1
        assert all(n == 1 and edges.get((b, a)) == 1 for (a, b), n in edges.items()), path.name
        volume = 0.0
        for a, b, c in triangles:
            (ax, ay, az), (bx, by, bz), (cx, cy, cz) = vertices[a], vertices[b], vertices[c]
            volume += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
        assert volume > 0, path.name
        assert abs(min(v[2] for v in vertices)) < 1e-9, path.name
