"""Household builders of long thin things: spoon, fork, knife, spatula, screwdriver, scissors, pliers, hammer.

Each takes a ``Draw`` (main dimension, its overall length in m, and variant already drawn for its split) and returns
a ``Shape`` of convex pieces in metres, canonical frame = resting pose: lying on the table (z up), long axis x.
"""

from __future__ import annotations

import math

import numpy as np

from pg_sim.objects.household_shapes import (
    PLASTIC,
    RUBBER,
    STEEL,
    WOOD,
    Draw,
    Parts,
    Shape,
    box,
    ellipse,
    ellipsoid,
    frustum,
    hull,
    moved,
    prism,
    rot,
    rounded_rect,
    stack,
    sweep,
)

Y_AXIS = (0.0, 1.0, 0.0)  # normal of paths in the x-z plane (handles rising off the table)
Z_AXIS = (0.0, 0.0, 1.0)  # normal of paths in the x-y plane (flat loops)


def _handle(d: Draw, x0: float, x1: float, z1: float, widths: tuple[float, float, float]) -> Parts:
    """A flat utensil handle from its end (x0, on the table) to (x1, z1), its neck raised in between; widths (m) at
    the end, the middle and the neck."""
    th = d.u("handle_thickness", 0.002, 0.0035)
    lift = d.u("neck_lift", 0.006, 0.012)
    xs = np.array([x0, x0 + 0.45 * (x1 - x0), x0 + 0.85 * (x1 - x0), x1])
    zs = np.array([th / 2, th / 2 + 0.55 * lift, z1 + 0.5 * lift, z1])
    w = [widths[0], widths[1], widths[2], widths[2] * 1.2]
    return sweep(np.column_stack([xs, np.zeros(4), zs]), [rounded_rect(th, wi) for wi in w], normal=Y_AXIS)


def spoon(d: Draw) -> Shape:
    """Spoon ``d.main`` m long: an elliptical shell bowl (oval or round, 6-10 mm deep, 1.5-2.5 mm thick) bottom down
    at +x, a handle resting on the table at x = 0."""
    length = d.main
    bl = length * d.u("bowl_share", 0.28, 0.34)
    bw = bl * (d.u("bowl_ratio", 0.55, 0.66) if d.variant == "oval" else d.u("bowl_ratio", 0.72, 0.82))
    dp, t = d.u("bowl_depth", 0.006, 0.010), d.u("shell", 0.0015, 0.0025)
    cx = length - bl / 2
    theta = 2 * np.pi * np.arange(13) / 12

    def shell(rho: float) -> np.ndarray:  # (12, 3) outer and (12, 3) inner points on the ring rho (0-1)
        c = math.sqrt(max(1 - rho * rho, 0.0))
        out = np.column_stack([cx + bl / 2 * rho * np.cos(theta), bw / 2 * rho * np.sin(theta),
                               np.full(13, dp * (1 - c))])
        inn = np.column_stack([cx + (bl / 2 - t) * rho * np.cos(theta), (bw / 2 - t) * rho * np.sin(theta),
                               np.full(13, dp - (dp - t) * c)])
        return np.vstack([out, inn])

    rings = [shell(r) for r in (0.0, 0.45, 0.78, 1.0)]
    pieces = [hull(np.vstack(rings[:2]))]
    for a, b in zip(rings[1:-1], rings[2:], strict=True):
        for k in range(12):
            idx = [k, k + 1, 13 + k, 14 + k]
            pieces.append(hull(np.vstack([a[idx], b[idx]])))
    pieces += _handle(d, 0.0, length - bl + 0.004, dp - 0.0015,
                      (d.u("end_width", 0.011, 0.016), 0.009, d.u("neck_width", 0.005, 0.007)))
    return Shape([(pieces, STEEL)])


def fork(d: Draw) -> Shape:
    """Fork ``d.main`` m long: three or four tines (28-40 mm) and a palm flat on the table at +x, a raised handle."""
    length, n = d.main, 3 if d.variant == "three" else 4
    tl, pl = d.u("tine_length", 0.028, 0.04), d.u("palm_length", 0.018, 0.026)
    hw, gap, t = d.u("head_width", 0.02, 0.027), d.u("gap", 0.0018, 0.0028), d.u("thickness", 0.0015, 0.0025)
    tw = (hw - (n - 1) * gap) / n
    x_palm = length - tl - pl
    pieces = [prism([(x_palm, -0.003), (x_palm + pl, -hw / 2), (x_palm + pl, hw / 2), (x_palm, 0.003)], 0.0, t)]
    for k in range(n):
        y = -hw / 2 + tw / 2 + k * (tw + gap)
        pieces.append(prism([(length - tl - 0.001, y - tw / 2), (length - 0.002, y - tw / 4), (length, y),
                             (length - 0.002, y + tw / 4), (length - tl - 0.001, y + tw / 2)], 0.0, t))
    pieces += _handle(d, 0.0, x_palm + 0.003, t / 2, (d.u("end_width", 0.011, 0.015), 0.008, 0.0055))
    return Shape([(pieces, STEEL)])


def knife(d: Draw) -> Shape:
    """Knife ``d.main`` m long: a blade 1-3 mm thick (wedge to a 40 % edge) flat on the table, table knife (round
    tip) or chef's knife (wide, pointed, bolster), and a handle 10-16 mm thick."""
    length = d.main
    hl = length * d.u("handle_share", 0.40, 0.48)
    hw, ht = d.u("handle_width", 0.016, 0.022), d.u("handle_thickness", 0.010, 0.016)
    bt = d.u("blade_thickness", 0.001, 0.003)
    chef = d.variant == "chef"
    bw = d.u("blade_width", 0.025, 0.040) if chef else d.u("blade_width", 0.014, 0.022)
    xb = hl + (0.008 if chef else 0.004)
    if chef:
        run = 0.4 * (length - xb)
        a = np.linspace(0, math.pi / 2, 6)[1:]
        tip = [(length - run + run * math.sin(v), -bw / 2 + (bw - 0.002) * (1 - math.cos(v))) for v in a]
    else:
        a = np.linspace(-math.pi / 2, math.pi / 2, 7)
        tip = [(length - bw / 2 + bw / 2 * math.cos(v), bw / 2 * math.sin(v)) for v in a]
    outline = [(xb - 0.002, -bw / 2), *tip, (xb - 0.002, bw / 2)]
    blade = hull([(x, y, z) for x, y in outline
                  for z in (0.0, bt * (0.4 + 0.6 * (y + bw / 2) / bw))])  # the wedge: spine bt, edge 0.4 bt
    handle = hull([(x, y, z + ht / 2) for x in (0.0, hl) for y, z in rounded_rect(hw if x else hw * 1.05, ht)])
    neck = box((xb - hl + 0.004, hw * 0.8, ht * 0.8) if chef else (xb - hl + 0.004, bw * 0.5, bt + 0.001),
               at=((hl + xb) / 2, 0.0, (ht * 0.8 if chef else bt + 0.001) / 2))
    return Shape([([blade, neck], STEEL), ([handle], WOOD if chef else STEEL * 0.6)])


def spatula(d: Draw) -> Shape:
    """Spatula (turner) ``d.main`` m long: a blade 55-80 mm wide, 1.5-3 mm thick, flat on the table at +x (solid or
    slotted), a neck rising 12-22 mm and a handle back down to the table at x = 0."""
    length = d.main
    bl, bw, bt = d.u("blade_length", 0.07, 0.10), d.u("blade_width", 0.055, 0.08), d.u("blade_thickness", 0.0015, 0.003)
    nl, zn = d.u("neck_length", 0.025, 0.04), d.u("neck_height", 0.012, 0.022)
    x0 = length - bl
    if d.variant == "slotted":
        bar, n_slots, slot = 0.012, 4, 0.004
        strip = (bw - n_slots * slot) / (n_slots + 1)
        pieces = [box((bar, bw, bt), (x0 + bar / 2, 0, bt / 2)), box((bar, bw, bt), (length - bar / 2, 0, bt / 2))]
        pieces += [box((bl - 2 * bar + 0.002, strip, bt), (x0 + bl / 2, -bw / 2 + strip / 2 + k * (strip + slot),
                                                             bt / 2)) for k in range(n_slots + 1)]
    else:
        c = 0.008
        pieces = [prism([(x0, -0.37 * bw), (length - c, -bw / 2), (length, -bw / 2 + c), (length, bw / 2 - c),
                         (length - c, bw / 2), (x0, 0.37 * bw)], 0.0, bt)]
    neck_path = [(x0 + 0.006, 0.0, bt / 2), (x0 - nl, 0.0, zn)]
    pieces += sweep(neck_path, rounded_rect(0.003, 0.012), normal=Y_AXIS)
    hw, ht = d.u("handle_width", 0.016, 0.022), d.u("handle_thickness", 0.007, 0.011)
    handle_path = [(x0 - nl + 0.004, 0.0, zn), (0.45 * (x0 - nl), 0.0, 0.5 * zn + ht / 2), (0.0, 0.0, ht / 2)]
    handle = sweep(handle_path, rounded_rect(ht, hw), normal=Y_AXIS)
    return Shape([(pieces, STEEL * 0.6), (handle, PLASTIC)])


def screwdriver(d: Draw) -> Shape:
    """Screwdriver ``d.main`` m long lying along x: an octagonal handle 22-32 mm across and 38-50 % of the length,
    a steel shaft 4-7 mm across, flat or cross tip."""
    length = d.main
    rh, rs = d.u("handle_diameter", 0.022, 0.032) / 2, d.u("shaft_diameter", 0.004, 0.007) / 2
    hl = length * d.u("handle_share", 0.38, 0.5)
    handle = stack([(0.65 * rh, 0.0), (0.95 * rh, 0.006), (rh, 0.012), (0.93 * rh, hl - 0.016), (0.95 * rh, hl - 0.01),
                    (0.45 * rh, hl)], n=8)
    shaft = [frustum(rs, hl - 0.004, rs, length - 0.008, n=8)]
    if d.variant == "flat":
        shaft.append(hull([*(frustum(rs, length - 0.008, rs, length - 0.0079, n=8).vertices),
                           *[(x, y, length) for x in (-rs * 1.1, rs * 1.1) for y in (-0.0004, 0.0004)]]))
    else:
        shaft.append(frustum(rs, length - 0.008, 0.12 * rs + 0.0003, length, n=8))
    turn = rot("y", math.pi / 2)  # the axis z onto x, an octagon face down
    return Shape([(moved(handle, turn), PLASTIC * 1.2), (moved(shaft, turn), STEEL)])


def _scissor_half(d: Draw, length: float, bl: float, bt: float, z0: float, mirror: float) -> tuple[Parts, Parts]:
    """One half of a pair of scissors along +x, pivot at the origin: (steel blade and shank, plastic ring)."""
    bw = d.u("blade_width", 0.012, 0.017)
    tip = 0.002 if d.variant == "pointed" else 0.006
    poly = [(-0.012, -bw / 2), (bl, -tip / 2), (bl - 0.003, tip / 2), (-0.012, bw / 2)]
    blade = prism([(x, mirror * y) for x, y in poly], z0, z0 + bt)
    rx, ry, rw = d.u("ring_x", 0.011, 0.016), d.u("ring_y", 0.008, 0.011), d.u("ring_width", 0.004, 0.006)
    rz = d.u("ring_thickness", 0.005, 0.008)
    cx, cy = -(length - bl) + rx + rw, -mirror * (ry + rw + 0.002)  # rings side by side, the blades crossed
    theta = 2 * np.pi * np.arange(10) / 10
    loop = np.column_stack([cx + (rx + rw / 2) * np.cos(theta), cy + (ry + rw / 2) * np.sin(theta),
                            np.full(10, rz / 2)])
    ring = sweep(loop, rounded_rect(rw, rz), normal=Z_AXIS, closed=True)
    shank = hull([(-0.01, mirror * y, z) for y in (-0.004, 0.004) for z in (z0, z0 + bt)]
                 + [(cx + rx * 0.6, cy + mirror * y, z) for y in (-0.003, 0.003) for z in (0.0, rz)])
    return [blade, shank], ring


def scissors(d: Draw) -> Shape:
    """Scissors ``d.main`` m long, lying flat: two steel blades (1.5-2.5 mm, pointed or blunt) crossed at a pivot,
    opened 3-20 deg, each with a plastic ring handle a finger goes through (hole 22-32 x 16-22 mm)."""
    length = d.main
    bl, bt = length * d.u("blade_share", 0.48, 0.56), d.u("blade_thickness", 0.0015, 0.0025)
    opening = d.u("opening", 0.05, 0.35)
    steel, plastic = [], []
    for mirror, z0, yaw in ((1.0, 0.0, opening / 2), (-1.0, bt, -opening / 2)):
        metal, ring = _scissor_half(d, length, bl, bt, z0, mirror)
        steel += moved(metal, rot("z", yaw))
        plastic += moved(ring, rot("z", yaw))
    steel.append(frustum(0.0035, 0.0, 0.0035, 2 * bt + 0.0008, n=8))
    return Shape([(steel, STEEL), (plastic, PLASTIC)])


def pliers(d: Draw) -> Shape:
    """Pliers ``d.main`` m long, lying flat: steel jaws (combination: short and blunt; needle: long and pointed)
    8-12 mm thick at a pivot, two handles spreading 24-44 mm with rubber grips."""
    length, jt = d.main, d.u("jaw_thickness", 0.008, 0.012)
    needle = d.variant == "needle"
    jl = length * (d.u("jaw_share", 0.33, 0.4) if needle else d.u("jaw_share", 0.22, 0.3))
    jw, tipw = d.u("jaw_width", 0.012, 0.016), 0.003 if needle else d.u("tip_width", 0.007, 0.01)
    pr = d.u("pivot_radius", 0.007, 0.01)
    steel, grips = [frustum(pr, 0.0, pr, jt, n=10)], []
    hl, spread = length - jl, d.u("spread", 0.012, 0.022)
    bw, bz = d.u("bar_width", 0.007, 0.01), jt * 0.7
    for s in (1.0, -1.0):
        jaw = [(0.0, s * 0.0003, z) for z in (0.0, jt)] + [(0.0, s * jw / 2, z) for z in (0.0, jt)]
        tip_z = (jt * 0.25, jt * 0.75) if needle else (0.0, jt)
        jaw += [(jl, s * 0.0003, z) for z in tip_z] + [(jl, s * tipw / 2, z) for z in tip_z]
        steel.append(hull(jaw))
        path = np.array([(0.002, s * 0.004, jt / 2), (-0.3 * hl, s * 0.008, jt / 2),
                         (-0.65 * hl, s * (0.006 + 0.6 * spread), jt / 2), (-hl, s * spread, jt / 2)])
        steel += sweep(path[:3], rounded_rect(bw, bz), normal=Z_AXIS)
        grips += sweep(path[1:], rounded_rect(bw + 0.005, bz + 0.004), normal=Z_AXIS)
    return Shape([(steel, STEEL), (grips, RUBBER)])


def hammer(d: Draw) -> Shape:
    """Hammer ``d.main`` m long (handle end to head), lying on its side: a wooden handle of oval section along x and
    a head along y: claw (two curved prongs), ball peen, or a rubber mallet's cylinder."""
    length = d.main
    hy = d.u("head_length", 0.08, 0.11)
    if d.variant == "mallet":
        r = d.u("head_diameter", 0.035, 0.048) / 2
        head = moved([frustum(r, -hy / 2, r, hy / 2, n=16)], rot("x", -math.pi / 2))
        sx, density = 2 * r, RUBBER
    else:
        s = d.u("head_size", 0.02, 0.026)
        sx, density = s, STEEL
        sec = rounded_rect(s, s)
        head = [hull([(x, y, z) for x, z in sec for y in (-0.2 * hy, 0.45 * hy)])]
        face = moved([frustum(0.55 * s, 0.0, 0.5 * s, 0.05 * hy, n=12)], rot("x", -math.pi / 2, (0, 0.45 * hy, 0)))
        head += face
        if d.variant == "peen":
            head += moved([frustum(0.35 * s, 0.0, 0.3 * s, 0.18 * hy, n=12)], rot("x", math.pi / 2, (0, -0.2 * hy, 0)))
            head.append(ellipsoid(0.5 * s, 0.5 * s, 0.5 * s, (0.0, -0.5 * hy + 0.5 * s, 0.0)))
        else:  # claw: two prongs curving towards the handle, split by a 3-5 mm slot
            gap = d.u("claw_gap", 0.003, 0.005)
            path = [(0.0, -0.18 * hy, 0.0), (-0.004, -0.32 * hy, 0.0), (-0.012, -0.42 * hy, 0.0),
                    (-0.024, -0.5 * hy, 0.0)]
            zt = (s - gap) / 2
            for zc in ((gap + zt) / 2, -(gap + zt) / 2):
                secs = [rounded_rect(w, zt * f, 0) + [0.0, zc] for w, f in
                        ((0.9 * s, 1.0), (0.6 * s, 0.9), (0.35 * s, 0.8), (0.12 * s, 0.6))]
                head += sweep(path, secs, normal=Z_AXIS)
    hw, ht = d.u("handle_width", 0.024, 0.03), d.u("handle_thickness", 0.017, 0.022)
    x_end = sx / 2 - length
    path = [(x_end, 0, 0), (x_end + 0.012, 0, 0), (0.5 * x_end, 0, 0), (0.0, 0, 0)]
    handle = sweep(path, [ellipse(hw / 2 * f, ht / 2 * f, 10) for f in (0.9, 1.0, 0.85, 0.8)], normal=Z_AXIS)
    return Shape([(head, density), (handle, WOOD)])
