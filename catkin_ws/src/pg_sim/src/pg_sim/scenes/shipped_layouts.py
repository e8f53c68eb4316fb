"""Write the shipped packed/ and household/ scene YAMLs (our own layouts, in the spirit of the paper's cases).

Each layout presses neighbours against a green target so that no gripper orientation fits around it at first.
Positions are in `world` (m), yaw in rad; objects start 1 mm above the table and 1-2 mm apart, then settle.
Run: python -m pg_sim.scenes.shipped_layouts, or scripts/make_scenes.py (overwrites the files under pg_sim's
scenes/{packed,household}/, the folder pg_core.resources.scene_folder() finds).
"""

from __future__ import annotations

import math
from dataclasses import replace

from pg_core.resources import scene_folder
from pg_sim.scenes.colors import resolve_color
from pg_sim.scenes.scene import ObjectSpec, SceneSpec
from pg_sim.scenes.scene_writer import save_scene

HEIGHT = {"cube": 0.045, "rect": 0.045, "triangle": 0.045, "arch": 0.045, "cylinder": 0.045, "half_cube": 0.045,
          "half_cylinder": 0.045}
OTHERS = ["blue", "brown", "orange", "yellow", "gray", "red", "purple", "cyan", "pink"]
H = 0.0225 + 0.001  # centre height of a 0.045 m block standing on the table
G = 0.0015  # gap between pressed neighbours (m)


def obj(shape, x, y, yaw=0.0, color=None, target=False, z=H, roll=0.0, pitch=0.0, name=""):
    return (shape, x, y, z, roll, pitch, yaw, color, target, name)


def rot(items, angle, dx, dy):
    """Rotate a whole layout by `angle` about the origin, then shift it by (dx, dy)."""
    c, s = math.cos(angle), math.sin(angle)
    out = []
    for shape, x, y, z, roll, pitch, yaw, color, target, name in items:
        out.append((shape, c * x - s * y + dx, s * x + c * y + dy, z, roll, pitch, yaw + angle, color, target, name))
    return out


def scene(name, family, items):
    objs, k = [], 0
    for i, (shape, x, y, z, roll, pitch, yaw, color, target, nm) in enumerate(items):
        if target:
            col = "green"
        else:
            col = color or OTHERS[k % len(OTHERS)]
            k += 1
        objs.append(ObjectSpec(shape=shape, size=None, color=resolve_color(col),
                               pose=(round(x, 4), round(y, 4), round(z, 4), roll, pitch, round(yaw, 4)),
                               target=target, name=nm or f"{shape}_{i}"))
    return SceneSpec(name=name, target="green", objects=tuple(objs), family=family)


S = 0.0225  # half block
L = 0.045  # long half of a rect


GRID = list(zip([(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)],
                ["cube", "cube", "cube", "cube", "cylinder", "cube", "cylinder", "cube"], strict=True))


def packed_layouts():
    t = 0.0
    yield "case01", rot([  # cube walled by four rects
        obj("cube", 0, 0, target=True),
        obj("rect", S + G + S, 0), obj("rect", -(S + G + S), 0),
        obj("rect", 0, S + G + S, yaw=math.pi / 2), obj("rect", 0, -(S + G + S), yaw=math.pi / 2),
        obj("cube", 2 * S + G + 0.002, 2 * S + G + 0.002),
    ], 0.3, 0.02, -0.01)
    yield "case02", rot([  # cylinder in a ring of cubes and triangles
        obj("cylinder", 0, 0, target=True),
        obj("cube", 0.022 + G + S, 0), obj("cube", -(0.022 + G + S), 0),
        obj("cube", 0, 0.022 + G + S), obj("cube", 0, -(0.022 + G + S)),
        obj("triangle", 0.022 + G + S, 2 * S + 2 * G + L, yaw=math.pi),
        obj("triangle", -(0.022 + G + S), -(2 * S + 2 * G + L)),
    ], -0.5, -0.01, 0.02)
    yield "case03", rot([  # rect target between long rects, capped by cubes
        obj("rect", 0, 0, target=True),
        obj("rect", 2 * S + G, 0), obj("rect", -(2 * S + G), 0),
        obj("cube", 0, L + G + S), obj("cube", 0, -(L + G + S)),
        obj("half_cube", 2 * S + G, L + G + S), obj("half_cube", -(2 * S + G), -(L + G + S)),
    ], 0.8, 0.0, 0.0)
    yield "case04", rot([  # cube held between two arches (notches facing it) and two rects
        obj("cube", 0, 0, target=True),
        obj("arch", 0, S + G + S, yaw=math.pi), obj("arch", 0, -(S + G + S)),
        obj("rect", L + G + S + 0.01, 0), obj("rect", -(L + G + S + 0.01), 0),
        obj("cylinder", 0, 2 * (S + G + S) + 0.005),
    ], 1.2, 0.01, 0.0)
    yield "case05", rot([  # triangle target in a nest of half cylinders and cubes
        obj("triangle", 0, 0, target=True),
        obj("half_cylinder", S + G + 0.011, 0.022, yaw=math.pi / 2),
        obj("half_cylinder", S + G + 0.011, -0.022, yaw=math.pi / 2),
        obj("rect", -(S + G + S), 0),
        obj("cube", 0, L + G + S), obj("cube", 0, -(L + G + S)),
    ], -1.0, -0.02, 0.0)
    yield "case06", rot([  # half cube target in a tight row
        obj("half_cube", 0, 0, target=True),
        obj("cube", 0.01125 + G + S, 0), obj("cube", -(0.01125 + G + S), 0),
        obj("rect", 0, S + G + S, yaw=math.pi / 2), obj("rect", 0, -(S + G + S), yaw=math.pi / 2),
        obj("half_cube", 0.01125 + 2 * G + 2 * S + 0.01125, 0), obj("cylinder", -(0.01125 + 2 * G + 2 * S + 0.022), 0),
    ], 0.15, 0.0, 0.01)
    yield "case07", rot([  # cube in a 3x3 grid of blocks
        obj("cube", 0, 0, target=True),
        *[obj(shape, dx * (2 * S + G), dy * (2 * S + G)) for (dx, dy), shape in GRID],
    ], 0.4, 0.0, 0.0)
    yield "case08", rot([  # twelve: cube target in two rings
        obj("cube", 0, 0, target=True),
        obj("rect", S + G + S, 0), obj("rect", -(S + G + S), 0),
        obj("rect", 0, S + G + S, yaw=math.pi / 2), obj("rect", 0, -(S + G + S), yaw=math.pi / 2),
        obj("cube", 2 * S + G, 2 * S + G), obj("cube", -(2 * S + G), -(2 * S + G)),
        obj("triangle", 2 * S + G, -(2 * S + G), yaw=math.pi / 2), obj("half_cube", -(2 * S + G) - 0.01, 2 * S + G),
        obj("rect", 4 * S + 2 * G, 0), obj("rect", -(4 * S + 2 * G), 0), obj("cylinder", 0, 4 * S + 2 * G + 0.002),
    ], -0.25, 0.0, 0.0)
    yield "case09", rot([  # cylinder cradled in an arch notch, boxed in
        obj("cylinder", 0, 0.002, target=True),
        obj("arch", 0, 0.0215 + G, yaw=math.pi),  # notch (+y of the arch) faces the cylinder
        obj("cube", 0.022 + G + S, -0.004), obj("cube", -(0.022 + G + S), -0.004),
        obj("rect", 0, -(0.022 + G + S), yaw=math.pi / 2),
        obj("half_cylinder", 0, -(0.022 + 2 * G + 2 * S + 0.011)),
    ], 2.0, 0.0, 0.0)
    del t


def household_layouts():
    yield "case11", [
        obj("milk_box", 0, 0, yaw=0.3, target=True, z=0.031),
        obj("soap", 0.0, 0.066, yaw=0.3, z=0.016), obj("mug", -0.07, -0.035, z=0.041),
        obj("glue", 0.065, -0.03, yaw=1.8, z=0.016, roll=math.pi / 2), obj("small_box", 0.0, -0.065, yaw=0.3, z=0.019),
    ]
    yield "case12", [
        obj("milk_box", 0.0, 0.0, yaw=1.4, target=True, z=0.031),
        obj("can", 0.072, 0.0, z=0.061), obj("can", -0.072, 0.0, z=0.061),
        obj("soap", 0.0, 0.07, yaw=0.0, z=0.016), obj("small_box", 0.0, -0.07, yaw=0.0, z=0.019),
        obj("mug", 0.09, 0.08, z=0.041),
    ]
    yield "case13", [
        obj("milk_box", 0.0, 0.0, yaw=-0.6, target=True, z=0.031),
        obj("bottle", 0.06, 0.05, yaw=-0.6, z=0.034, roll=math.pi / 2),
        obj("bottle", -0.06, -0.05, yaw=-0.6, z=0.034, roll=math.pi / 2),
        obj("mug", 0.075, -0.055, z=0.041), obj("glue", -0.07, 0.06, z=0.016, roll=math.pi / 2, yaw=0.9),
        obj("soap", 0.0, 0.11, z=0.016),
    ]
    yield "case14", [
        obj("milk_box", 0.0, 0.0, yaw=0.0, target=True, z=0.031),
        obj("small_box", 0.0, 0.058, z=0.019), obj("small_box", 0.0, -0.058, z=0.019),
        obj("soap", 0.075, 0.0, yaw=math.pi / 2, z=0.016), obj("can", -0.085, 0.0, z=0.061),
        obj("mug", 0.07, 0.09, z=0.041), obj("glue", -0.06, -0.09, z=0.016, roll=math.pi / 2),
    ]


def on_table(spec: SceneSpec) -> SceneSpec:
    """Shift each object vertically so its lowest point is 1 mm above the table (AABB from PyBullet)."""
    import pybullet as p

    from pg_sim.scenes.objects import spawn_object

    client = p.connect(p.DIRECT)
    objs = []
    for o in spec.objects:
        body = spawn_object(client, o)
        lo, _ = p.getAABB(body, physicsClientId=client)
        objs.append(replace(o, pose=(o.pose[0], o.pose[1], round(o.pose[2] - lo[2] + 0.001, 4), *o.pose[3:])))
        p.removeBody(body, physicsClientId=client)
    p.disconnect(client)
    return replace(spec, objects=tuple(objs))


def main() -> None:
    out = scene_folder()
    for name, items in packed_layouts():
        save_scene(on_table(scene(f"packed/{name}", "packed", items)), out / "packed" / f"{name}.yaml")
    for name, items in household_layouts():
        save_scene(on_table(scene(f"household/{name}", "household", items)), out / "household" / f"{name}.yaml")
    print(f"wrote scenes under {out}")


if __name__ == "__main__":
    main()
