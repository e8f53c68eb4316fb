"""Household builders of round things: bowl, plate, cup, mug, bottle, can (pg_sim.objects.household).

Each takes a ``Draw`` (main dimension and variant already drawn for its split) and returns a ``Shape`` of convex
pieces in metres, canonical frame: the axis of revolution is z, the bottom at z = 0. Containers are thin revolved
walls on a foot or a flat bottom, so their cavity is real in physics.
"""

from __future__ import annotations

import math

import numpy as np

from pg_sim.objects.household_shapes import (
    CERAMIC,
    PLASTIC,
    Draw,
    Parts,
    Shape,
    frustum,
    revolve,
    rounded_rect,
    stack,
    sweep,
    wall,
)

LYING = (0.0, math.pi / 2, 0.0)  # rest pose of a lying bottle or can: its axis (z) along world x, a face down


def _arc(r0: float, z0: float, r1: float, z1: float, k: int, start: float = 0.0) -> np.ndarray:
    """(k + 1, 2) points of a quarter ellipse from (r0, z0) (horizontal tangent) to (r1, z1) (vertical tangent),
    starting at ``start`` of the quarter (0-1)."""
    phi = np.linspace(start, 1.0, k + 1) * math.pi / 2
    return np.column_stack([r0 + (r1 - r0) * np.sin(phi), z0 + (z1 - z0) * (1 - np.cos(phi))])


def _foot(r_out: float, width: float, height: float) -> Parts:
    return revolve([(r_out - width, 0.0), (r_out, 0.0), (r_out, height), (r_out - width, height)], 10)


def bowl(d: Draw) -> Shape:
    """Round bowl on a foot ring: outer diameter ``d.main`` (m), height 0.3-0.45 of it, wall 3-5 mm."""
    r, t = d.main / 2, d.u("wall", 0.003, 0.005)
    h = d.main * d.u("height_ratio", 0.3, 0.45)
    rf, hf = r * d.u("foot_ratio", 0.36, 0.46), d.u("foot_height", 0.005, 0.008)
    outer = _arc(rf, hf, r, h, 4)
    pieces = [frustum(rf, hf, rf, hf + t), *_foot(rf, d.u("foot_width", 0.004, 0.006), hf), *wall(outer, t)]
    return Shape([(pieces, CERAMIC * d.u("density_share", 0.85, 1.0))], inner_radius=r - t, inner_depth=h - hf - t)


def plate(d: Draw) -> Shape:
    """Plate: a flat well and a low sloped rim, diameter ``d.main`` (m), 15-25 mm high, 3-5 mm thick."""
    r, t = d.main / 2, d.u("thickness", 0.003, 0.005)
    h = d.u("height", 0.015, 0.025)
    rb, hf = r * d.u("well_ratio", 0.55, 0.7), d.u("foot_height", 0.003, 0.005)
    w, top = r - rb, h
    outer = np.array([(rb, hf), (rb + 0.12 * w, hf + 0.5 * (top - hf)), (rb + 0.35 * w, hf + 0.85 * (top - hf)),
                      (r, top)])
    pieces = [frustum(rb, hf, rb, hf + t), *_foot(rb * d.u("foot_ratio", 0.8, 0.95), 0.004, hf), *wall(outer, t)]
    density = CERAMIC if d.variant == "ceramic" else PLASTIC * 1.5  # melamine
    return Shape([(pieces, density)], inner_radius=rb, inner_depth=top - hf - t)


def _cup_body(d: Draw, height: float, top_d: float, taper: float) -> tuple[Parts, float, float]:
    """A cup's wall on a flat bottom: pieces, wall thickness and bottom thickness (m)."""
    t, tb = d.u("wall", 0.003, 0.005), d.u("bottom", 0.005, 0.008)
    r1 = top_d / 2
    r0 = r1 * taper
    slope = (r1 - r0) / height
    outer = np.array([(r0, 0.0), (r0 + slope * height * 0.5, height * 0.5), (r1, height)])
    return [frustum(r0, 0.0, r0 + slope * tb, tb), *wall(outer, t)], t, tb


def cup(d: Draw) -> Shape:
    """Cup without a handle, height ``d.main`` (m), top diameter 0.06-0.082, straight or tapered."""
    top = d.u("top_diameter", 0.06, 0.082)
    taper = 1.0 if d.variant == "straight" else d.u("taper", 0.68, 0.9)
    pieces, t, tb = _cup_body(d, d.main, top, taper)
    density = CERAMIC if d.variant == "straight" else PLASTIC * 1.2
    return Shape([(pieces, density)], inner_radius=top / 2 - t, inner_depth=d.main - tb)


def _handle_path(x_wall: float, reach: float, z_low: float, z_high: float, square: bool) -> np.ndarray:
    """Centre line (x, 0, z) of a mug handle from the wall at z_low out to ``reach`` and back at z_high."""
    zc, b = (z_low + z_high) / 2, (z_high - z_low) / 2
    if not square:
        psi = np.linspace(-math.pi / 2, math.pi / 2, 9)
        return np.column_stack([x_wall + reach * np.cos(psi), np.zeros(9), zc + b * np.sin(psi)])
    c = min(reach, b) * 0.45  # corner radius of the D-shaped handle
    corner = np.linspace(0, math.pi / 2, 3)
    pts = [(x_wall, z_low), (x_wall + reach - c, z_low)]
    pts += [(x_wall + reach - c + c * math.sin(a), z_low + c - c * math.cos(a)) for a in corner[1:]]
    pts += [(x_wall + reach, z_high - c)]
    pts += [(x_wall + reach - c + c * math.cos(a), z_high - c + c * math.sin(a)) for a in corner[1:]]
    pts += [(x_wall, z_high)]
    return np.array([(x, 0.0, z) for x, z in pts])


def mug(d: Draw) -> Shape:
    """Mug with a handle a finger goes through: height ``d.main`` (m), diameter 0.07-0.085, handle reach 25-35 mm
    (round C or square D shape), finger hole at least 18 x 25 mm."""
    h, dia = d.main, d.u("diameter", 0.07, 0.085)
    pieces, t, tb = _cup_body(d, h, dia, 1.0)
    bar_w, bar_t = d.u("handle_width", 0.010, 0.014), d.u("handle_thickness", 0.007, 0.010)
    reach = d.u("handle_reach", 0.025, 0.035)
    z_high = h - d.u("handle_top", 0.012, 0.02)
    z_low = min(d.u("handle_bottom", 0.012, 0.025), z_high - 0.045)
    x_wall = dia / 2 - t / 2  # the handle's ends sink into the wall
    path = _handle_path(x_wall, reach + t / 2 - bar_t / 2, z_low + bar_t / 2, z_high - bar_t / 2,
                        d.variant == "square")
    handle = sweep(path, rounded_rect(bar_t, bar_w), normal=(0.0, -1.0, 0.0))
    return Shape([(pieces + handle, CERAMIC)], inner_radius=dia / 2 - t, inner_depth=h - tb)


def bottle(d: Draw) -> Shape:
    """Closed bottle, height ``d.main`` (m), body diameter 0.05-0.08, shoulder, neck 22-30 mm, cap; standing or lying
    (``rest_rpy``); an effective density of a part-filled plastic bottle."""
    h, r = d.main, d.u("diameter", 0.05, 0.08) / 2
    rn = d.u("neck_radius", 0.011, 0.015)
    cap_h, zb = d.u("cap_height", 0.014, 0.022), h * d.u("body_share", 0.55, 0.65)
    zs = zb + (h - cap_h - zb) * d.u("shoulder_share", 0.45, 0.65)
    c = 0.004
    prof = [(r - c, 0.0), (r, c), (r, zb)]
    for s in (0.25, 0.5, 0.75, 1.0):  # the shoulder: a cosine from the body to the neck
        prof.append((rn + (r - rn) * (1 + math.cos(math.pi * s)) / 2, zb + (zs - zb) * s))
    zr = h - cap_h
    prof += [(rn, zr - 0.004), (rn + 0.0025, zr - 0.004), (rn + 0.0025, zr - 0.002), (rn, zr - 0.002), (rn, zr)]
    rc = rn + d.u("cap_rim", 0.0015, 0.003)
    prof += [(rc, zr), (rc, h - 0.002), (rc - 0.002, h)]
    pieces = stack(prof)
    return Shape([(pieces, d.u("density", 200.0, 450.0))], rest_rpy=LYING if d.variant == "lying" else (0, 0, 0))


def can(d: Draw) -> Shape:
    """Closed can, height ``d.main`` (m), diameter 0.052-0.075, with bottom and top chamfers and a raised rim around
    a recessed lid; standing or lying (``rest_rpy``)."""
    h, r = d.main, d.u("diameter", 0.052, 0.075) / 2
    c, lid = 0.0045, 0.003
    prof = [(r - c, 0.0), (r, 0.006), (r, h - 0.01), (r - c, h - lid)]
    rim = revolve([(r - c - 0.0022, h - lid - 0.0005), (r - c, h - lid - 0.0005), (r - c + 0.0004, h),
                   (r - c - 0.0018, h)])
    return Shape([(stack(prof) + rim, d.u("density", 350.0, 900.0))],
                 rest_rpy=LYING if d.variant == "lying" else (0, 0, 0))

