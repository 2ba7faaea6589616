"""Writes the shipped cabinet, `assets/cabinet/cabinet.urdf`: a carcass with one drawer on a
prismatic joint, made for this project (no downloads), every part a box. The output is
deterministic: running the script again writes the same bytes, which
`tests/python/test_object_assets.py` checks.

    python scripts/make_cabinet.py [--out assets/cabinet]

Frames (metres): the cabinet's origin is on the floor under the middle of its carcass, +x out
of its front (the way the drawer opens), +z up. The drawer's link frame coincides with the
cabinet's when the drawer is shut; its joint `drawer_joint` slides it along +x from 0 (shut)
to `TRAVEL` (open). A frame-only link `handle` sits on the knob's stem, where a gripper closes
(fingers closing along y, the hand above the stem; the knob's head stops fingers that pull).
"""

from __future__ import annotations

import argparse
from pathlib import Path

# Carcass (outer sizes) and panel thickness.
DEPTH, WIDTH, HEIGHT, PANEL = 0.30, 0.40, 0.30, 0.015
# How far the drawer slides out, its mass (kg) and its slide's damping (N s/m) and dry
# friction (N): it stays where it is left and a hand pulls it open with a few newtons.
TRAVEL, DRAWER_MASS, DAMPING, FRICTION = 0.25, 1.5, 5.0, 2.0
# The drawer: its front panel's thickness and how far its top rises above the knob's stem, the
# box behind it, and the knob (a stem out of the front and a head at its end).
FRONT, FRONT_ABOVE_STEM = 0.02, 0.03
BOX_DEPTH, BOX_HEIGHT = 0.26, 0.12
STEM_LENGTH, STEM_SIDE = 0.055, 0.02
HEAD_DEPTH, HEAD_WIDTH, HEAD_HEIGHT = 0.015, 0.07, 0.05
# The stem's height below the carcass top. The hand's palm, 4.5 cm above the tool centre point
# and 6.3 cm across (along x when the fingers close on the stem), reaches 3.2 cm towards the
# cabinet from the grasp point: it clears the carcass (1.6 cm short of it) and passes above the
# drawer's front panel (1.5 cm above its top).
STEM_BELOW_TOP = 0.065
# Colours (diffuse RGB).
WOOD, FRONT_COLOUR, METAL = (0.62, 0.45, 0.28), (0.80, 0.70, 0.52), (0.55, 0.57, 0.60)


def box(name: str, size: tuple, centre: tuple, colour: tuple) -> str:
    """One box as a collision and a visual element of a link."""
    s = " ".join(f"{v:.4f}" for v in size)
    c = " ".join(f"{v:.4f}" for v in centre)
    rgba = " ".join(f"{v:.2f}" for v in colour) + " 1"
    return (
        f'    <visual name="{name}"><origin xyz="{c}"/><geometry><box size="{s}"/></geometry>'
        f'<material name="{name}"><color rgba="{rgba}"/></material></visual>\n'
        f'    <collision name="{name}"><origin xyz="{c}"/><geometry><box size="{s}"/>'
        f"</geometry></collision>\n"
    )


def inertial(mass: float, size: tuple, centre: tuple) -> str:
    """A solid box's inertia at `centre` (the drawer's mass spread over its outline)."""
    x, y, z = size
    ixx, iyy, izz = (mass / 12 * (b * b + c * c) for b, c in ((y, z), (x, z), (x, y)))
    c = " ".join(f"{v:.4f}" for v in centre)
    return (
        f'    <inertial><origin xyz="{c}"/><mass value="{mass}"/>'
        f'<inertia ixx="{ixx:.6f}" ixy="0" ixz="0" iyy="{iyy:.6f}" iyz="0" izz="{izz:.6f}"/>'
        "</inertial>\n"
    )


def cabinet() -> str:
    front_x = DEPTH / 2
    carcass = [
        ("bottom", (DEPTH, WIDTH, PANEL), (0.0, 0.0, PANEL / 2)),
        ("top", (DEPTH, WIDTH, PANEL), (0.0, 0.0, HEIGHT - PANEL / 2)),
        ("left", (DEPTH, PANEL, HEIGHT), (0.0, WIDTH / 2 - PANEL / 2, HEIGHT / 2)),
        ("right", (DEPTH, PANEL, HEIGHT), (0.0, -WIDTH / 2 + PANEL / 2, HEIGHT / 2)),
        ("back", (PANEL, WIDTH, HEIGHT), (-DEPTH / 2 + PANEL / 2, 0.0, HEIGHT / 2)),
    ]
    # The drawer: its front closes the opening (flush with the carcass's front edge), the box
    # behind it runs on the carcass bottom's top face with 2 mm to spare on every side.
    inner_w = WIDTH - 2 * PANEL - 0.004
    stem_z = HEIGHT - STEM_BELOW_TOP
    front_top = stem_z + FRONT_ABOVE_STEM
    front_bottom = PANEL + 0.002
    box_bottom = PANEL + 0.002
    back_x = front_x - BOX_DEPTH
    stem_x = front_x + FRONT + STEM_LENGTH / 2
    head_x = front_x + FRONT + STEM_LENGTH + HEAD_DEPTH / 2
    drawer = [
        (
            "front",
            (FRONT, inner_w, front_top - front_bottom),
            (front_x + FRONT / 2, 0.0, (front_top + front_bottom) / 2),
            FRONT_COLOUR,
        ),
        (
            "floor",
            (BOX_DEPTH, inner_w, 0.01),
            (front_x - BOX_DEPTH / 2, 0.0, box_bottom + 0.005),
            WOOD,
        ),
        (
            "left_side",
            (BOX_DEPTH, 0.01, BOX_HEIGHT),
            (front_x - BOX_DEPTH / 2, inner_w / 2 - 0.005, box_bottom + BOX_HEIGHT / 2),
            WOOD,
        ),
        (
            "right_side",
            (BOX_DEPTH, 0.01, BOX_HEIGHT),
            (front_x - BOX_DEPTH / 2, -inner_w / 2 + 0.005, box_bottom + BOX_HEIGHT / 2),
            WOOD,
        ),
        (
            "rear",
            (0.01, inner_w, BOX_HEIGHT),
            (back_x + 0.005, 0.0, box_bottom + BOX_HEIGHT / 2),
            WOOD,
        ),
        ("stem", (STEM_LENGTH, STEM_SIDE, STEM_SIDE), (stem_x, 0.0, stem_z), METAL),
        ("head", (HEAD_DEPTH, HEAD_WIDTH, HEAD_HEIGHT), (head_x, 0.0, stem_z), METAL),
    ]
    out = ['<?xml version="1.0"?>\n']
    out.append("<!-- Written by scripts/make_cabinet.py; do not edit by hand. -->\n")
    out.append('<robot name="cabinet">\n')
    out.append('  <link name="cabinet">\n')
    out.append(inertial(10.0, (DEPTH, WIDTH, HEIGHT), (0.0, 0.0, HEIGHT / 2)))
    for name, size, centre in carcass:
        out.append(box(name, size, centre, WOOD))
    out.append("  </link>\n")
    out.append('  <link name="drawer">\n')
    out.append(
        inertial(
            DRAWER_MASS,
            (BOX_DEPTH, inner_w, BOX_HEIGHT),
            (front_x - BOX_DEPTH / 2, 0.0, box_bottom + BOX_HEIGHT / 2),
        )
    )
    for name, size, centre, colour in drawer:
        out.append(box(name, size, centre, colour))
    out.append("  </link>\n")
    out.append('  <link name="handle"/>\n')
    out.append(
        '  <joint name="drawer_joint" type="prismatic">\n'
        '    <parent link="cabinet"/><child link="drawer"/>\n'
        '    <origin xyz="0 0 0"/><axis xyz="1 0 0"/>\n'
        f'    <limit lower="0" upper="{TRAVEL}" effort="100" velocity="1"/>\n'
        f'    <dynamics damping="{DAMPING}" friction="{FRICTION}"/>\n'
        "  </joint>\n"
    )
    grasp_x = front_x + FRONT + 0.5 * STEM_LENGTH
    out.append(
        '  <joint name="handle_joint" type="fixed">\n'
        '    <parent link="drawer"/><child link="handle"/>\n'
        f'    <origin xyz="{grasp_x:.4f} 0 {stem_z:.4f}"/>\n'
        "  </joint>\n"
    )
    out.append("</robot>\n")
    return "".join(out)


README = """# The cabinet

`cabinet.urdf`: a carcass 30 x 40 x 30 cm (depth, width, height) with one drawer on a prismatic
joint (`drawer_joint`, 0 to 0.25 m along the cabinet's +x, damping 5 N s/m, friction 2 N, the
drawer 1.5 kg) and a knob on the drawer's front; the frame-only link `handle` marks where a
gripper closes on the knob's stem. Every part is a box.

Made by `scripts/make_cabinet.py` for this project (no downloads); the same licence as the
repository.
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("assets/cabinet"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "cabinet.urdf").write_text(cabinet())
    (args.out / "README.md").write_text(README)


if __name__ == "__main__":
    main()
