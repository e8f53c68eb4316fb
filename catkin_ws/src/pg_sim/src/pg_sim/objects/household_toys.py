"""Household builders of toys and fruit: toy_airplane, toy_car, brick, fruit (pg_sim.objects.household).

Each takes a ``Draw`` (main dimension and variant already drawn for its split) and returns a ``Shape`` of convex
pieces in metres, canonical frame = resting pose (z up; long axis x).
"""

from __future__ import annotations

import math

import numpy as np

from pg_sim.objects.household_shapes import (
    ABS,
    PLASTIC,
    Draw,
    Parts,
    Shape,
    box,
    ellipse,
    frustum,
    hull,
    moved,
    prism,
    rot,
    stack,
    sweep,
)

ALONG_X = rot("y", math.pi / 2)  # a solid built along z turned to lie along +x (its +x face down)
ALONG_Y = rot("x", -math.pi / 2)  # ... along +y (its +y face down)


def _wheel(radius: float, width: float, at: tuple[float, float, float], n: int = 12) -> Parts:
    m = rot("x", -math.pi / 2, at)
    return moved([frustum(radius, -width / 2, radius, width / 2, n=n)], m)


def toy_airplane(d: Draw) -> Shape:
    """Toy airplane ``d.main`` m long (spinner or nose to tail): a fuselage of frusta, thin swept wings (3-5 mm),
    tailplane and fin; ``prop``: a propeller and a tricycle gear it stands on; ``jet``: two engines through the
    wings, level with the belly it rests on."""
    length = d.main / (1.06 if d.variant == "prop" else 1.0)  # the fuselage: a spinner adds 6 % in front of it
    fr = length * d.u("fuselage_ratio", 0.075, 0.1)
    rise = 0.6 * fr  # the tail is raised: frusta centres move up (-x before the turn)
    prof = [(0.3, 0.0, 0.0), (0.8, 0.06, 0.0), (1.0, 0.15, 0.0), (1.0, 0.55, 0.0), (0.7, 0.8, 0.4), (0.35, 1.0, 1.0)]
    body = [frustum(r0 * fr, z0 * length, r1 * fr, z1 * length, n=12, c0=(-u0 * rise, 0.0), c1=(-u1 * rise, 0.0))
            for (r0, z0, u0), (r1, z1, u1) in zip(prof[:-1], prof[1:], strict=True)]
    parts = moved(body, ALONG_X)
    span, chord = length * d.u("span_ratio", 0.9, 1.15), length * d.u("chord_ratio", 0.18, 0.25)
    wt, sweep_back = d.u("wing_thickness", 0.003, 0.005), chord * d.u("sweep", 0.2, 0.6)
    xl, zw = 0.35 * length, -0.65 * fr
    dihedral = span / 2 * math.tan(math.radians(d.u("dihedral_deg", 1.0, 5.0)))
    for s in (1.0, -1.0):
        root = [(xl, 0.0), (xl + chord, 0.0)]
        tip = [(xl + sweep_back, s * span / 2), (xl + sweep_back + 0.5 * chord, s * span / 2)]
        parts.append(hull([(x, y, zw + z) for x, y in root for z in (0, wt)]
                          + [(x, y, zw + dihedral + z) for x, y in tip for z in (0, wt)]))
        tail_z, tc = rise, 0.5 * chord
        parts.append(prism([(length - tc, 0.0), (length, 0.0), (length, s * 0.35 * span / 2),
                            (length - 0.5 * tc, s * 0.35 * span / 2)], tail_z, tail_z + wt))
    fin_h = 1.6 * fr
    parts.append(hull([(x, y, z) for y in (-wt / 2, wt / 2) for x, z in
                       ((length - 0.6 * chord, rise), (length, rise), (length, rise + fin_h),
                        (length - 0.2 * chord, rise + fin_h))]))
    if d.variant == "prop":
        parts += moved([frustum(0.35 * fr, 0.0, 0.1 * fr, 0.06 * length, n=12)], rot("y", -math.pi / 2))
        parts.append(box((0.003, 2.4 * fr, 0.25 * fr), (-0.002, 0.0, 0.0)))
        wr = 0.3 * fr
        z_wheel = -fr - 0.8 * wr  # tricycle gear: the main wheels behind the centre of the bounding box
        for x, y in ((0.62 * length, 1.7 * fr), (0.62 * length, -1.7 * fr), (0.1 * length, 0.0)):
            parts += _wheel(wr, 0.4 * wr + 0.002, (x, y, z_wheel))
            parts.append(hull([(x + dx, y * f + dy, z) for dx in (-0.0015, 0.0015) for dy in (-0.0015, 0.0015)
                               for f, z in ((1.0, z_wheel), (0.3, -0.7 * fr))]))  # strut to the fuselage
    else:
        nr = 0.42 * fr
        for s in (1.0, -1.0):
            y = s * span * 0.22
            eng = frustum(0.8 * nr, 0.0, nr, 0.1 * chord, c0=(0.0, y), c1=(0.0, y), n=12)
            parts += moved([eng, frustum(nr, 0.1 * chord, 0.85 * nr, 0.7 * chord, c0=(0.0, y), c1=(0.0, y), n=12)],
                           rot("y", math.pi / 2, (xl - 0.1 * chord, 0.0, -fr + nr)))
    return Shape([(parts, PLASTIC * d.u("density_share", 0.5, 0.9))])


def toy_car(d: Draw) -> Shape:
    """Toy car ``d.main`` m long standing on four wheels: a chamfered body, a cabin (sedan), a tall cabin (van) or a
    short cabin and an open bed (pickup)."""
    length = d.main
    w, wr = length * d.u("width_ratio", 0.38, 0.48), length * d.u("wheel_ratio", 0.11, 0.15)
    ww, bh = d.u("wheel_width", 0.006, 0.011), w * d.u("body_ratio", 0.32, 0.45)
    zb, a = 0.55 * wr, length / 2
    side = [(-a, zb + 0.2 * bh), (-a + 0.05 * length, zb), (a - 0.05 * length, zb), (a, zb + 0.25 * bh),
            (a - 0.03 * length, zb + bh), (-a + 0.03 * length, zb + bh)]
    parts = [hull([(x, y, z) for x, z in side for y in (-w / 2, w / 2)])]
    top, ch, cw = zb + bh, bh * d.u("cabin_ratio", 0.6, 0.9), 0.85 * w
    cabins = {"sedan": ((-0.25, 0.2), (-0.18, 0.05)), "van": ((-0.47, 0.3), (-0.47, 0.18)),
              "pickup": ((-0.05, 0.22), (-0.03, 0.12))}
    (b0, b1), (t0, t1) = cabins[d.variant]
    parts.append(hull([(x * length, y, z) for y in (-cw / 2, cw / 2)
                       for x, z in ((b0, top - 0.001), (b1, top - 0.001), (t1, top + ch), (t0, top + ch))]))
    if d.variant == "pickup":  # the bed: side walls and a tailgate on the body's rear deck
        x0, x1, hwall = -a + 0.03 * length, -0.05 * length, 0.35 * ch
        parts += [box((x1 - x0, 0.003, hwall), ((x0 + x1) / 2, s * (w / 2 - 0.0015), top + hwall / 2))
                  for s in (1.0, -1.0)]
        parts.append(box((0.003, w, hwall), (x0 + 0.0015, 0.0, top + hwall / 2)))
    xw = a - 1.25 * wr
    for x in (xw, -xw):
        for s in (1.0, -1.0):
            parts += _wheel(wr, ww, (x, s * (w / 2 - ww / 2 + 0.0015), wr))
    return Shape([(parts, PLASTIC * d.u("density_share", 0.5, 0.9))])


LAYOUTS = {"1x2": (2, 1), "2x2": (2, 2), "1x3": (3, 1), "1x4": (4, 1), "2x4": (4, 2), "2x3": (3, 2)}


def brick(d: Draw) -> Shape:
    """Toy brick of stud pitch ``d.main`` m (8 mm: LEGO-like, 16 mm: DUPLO-like) and a stud layout (variant
    "<across>x<along>"), 1.2 pitches high: studs on top, hollow underneath with walls and tubes (or pins)."""
    p = d.main
    nx, ny = LAYOUTS[d.variant]
    sx, sy, h = nx * p, ny * p, 1.2 * p
    tt, wt = 0.125 * p, 0.15 * p
    parts = [box((sx, sy, tt), (0.0, 0.0, h - tt / 2)),
             box((sx, wt, h), (0.0, sy / 2 - wt / 2, h / 2)), box((sx, wt, h), (0.0, -sy / 2 + wt / 2, h / 2)),
             box((wt, sy, h), (sx / 2 - wt / 2, 0.0, h / 2)), box((wt, sy, h), (-sx / 2 + wt / 2, 0.0, h / 2))]
    for i in range(nx):
        for j in range(ny):
            c = ((i + 0.5) * p - sx / 2, (j + 0.5) * p - sy / 2)
            parts.append(frustum(0.3 * p, h - 0.001, 0.3 * p, h + 0.2 * p, n=12, c0=c))
    if ny > 1:
        tubes = [((i + 1) * p - sx / 2, (j + 1) * p - sy / 2, 0.4 * p) for i in range(nx - 1) for j in range(ny - 1)]
    else:
        tubes = [((i + 1) * p - sx / 2, 0.0, 0.15 * p) for i in range(nx - 1)]
    parts += [frustum(r, 0.0, r, h - tt + 0.001, n=12, c0=(x, y)) for x, y, r in tubes]
    return Shape([(parts, ABS)])


def _revolved(radius: float, height: float, profile: list[tuple[float, float]]) -> Parts:
    return stack([(r * radius, z * height) for r, z in profile])


def _stem(z0: float, length: float, lean: float) -> Parts:
    return [frustum(0.0022, z0, 0.0016, z0 + length, n=8, c1=(lean, 0.0))]


def fruit(d: Draw) -> Shape:
    """Fruit-like: apple (d 65-82 mm, flat-bottomed, stem), orange (d 60-82 mm, oblate), banana (150-220 mm long,
    30-38 mm thick, curved, five-sided, lying on a side) or pear (d 60-80 mm, 1.3-1.5 times as tall). ``d.main`` is
    the size within the variant's range, 0-1."""
    s = d.main
    if d.variant == "apple":
        r, h = (0.065 + 0.017 * s) / 2, (0.065 + 0.017 * s) * d.u("height_ratio", 0.82, 0.92)
        prof = [(0.3, 0.0), (0.7, 0.08), (0.93, 0.25), (1.0, 0.5), (0.97, 0.7), (0.8, 0.88), (0.42, 1.0)]
        return Shape([(_revolved(r, h, prof) + _stem(h - 0.004, d.u("stem", 0.012, 0.018), 0.002), 820.0)])
    if d.variant == "orange":
        r = (0.06 + 0.022 * s) / 2
        h = 2 * r * d.u("height_ratio", 0.9, 0.97)
        zs = np.array([0.0, 0.04, 0.15, 0.32, 0.5, 0.68, 0.85, 0.96, 1.0])
        prof = [(max(math.sqrt(max(1 - (2 * z - 1) ** 2, 0.0)), 0.25), z) for z in zs]
        top = frustum(0.004, h - 0.0005, 0.0025, h + 0.0012, n=8)
        return Shape([(_revolved(r, h, prof) + [top], 900.0)])
    if d.variant == "pear":
        r = (0.06 + 0.02 * s) / 2
        h = 2 * r * d.u("height_ratio", 1.3, 1.5)
        prof = [(0.3, 0.0), (0.75, 0.06), (1.0, 0.25), (0.92, 0.45), (0.62, 0.62), (0.45, 0.78), (0.38, 0.9),
                (0.18, 1.0)]
        return Shape([(_revolved(r, h, prof) + _stem(h - 0.003, d.u("stem", 0.012, 0.02), 0.003), 950.0)])
    length, thick = 0.15 + 0.07 * s, d.u("thickness", 0.03, 0.038)
    bend = length * d.u("bend_radius_ratio", 0.75, 1.1)
    arc = length / bend
    t = np.linspace(0.0, 1.0, 9)
    phi = (t - 0.5) * arc
    path = np.column_stack([bend * np.sin(phi), bend * (1 - np.cos(phi)), np.full(9, thick / 2)])
    radii = thick / 2 * (0.35 + 0.65 * np.sin(np.pi * t) ** 0.6)
    secs = [ellipse(r, r, 5) + [0.0, r - thick / 2] for r in radii]  # a flat side down, resting on the table
    parts = sweep(path, secs, normal=(0.0, 0.0, 1.0))
    tangent = path[0] - path[1]
    tangent /= np.linalg.norm(tangent)
    stem_end = path[0] + 0.02 * tangent
    parts += sweep([path[0], stem_end], [ellipse(0.004, 0.004, 4) + [0.0, radii[0] - thick / 2]] * 2,
                   normal=(0.0, 0.0, 1.0))
    return Shape([(parts, 950.0)])

