"""One builder per category of the synthetic shapes: a generator in, a list of parts out.

Each builder draws the proportions and optional parts of one shape from the
``np.random.Generator`` it is given, in the canonical frame of
:mod:`vptoolkit.synthetic` (``+z`` up, ``+x`` front, mirror plane ``y = 0``,
floor at ``z = 0`` before centring). :data:`_BUILDERS` maps each category
name to its builder.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from vptoolkit.synthetic._parts import (
    _Z_TO_X,
    _Z_TO_Y,
    _block,
    _box,
    _centred_box,
    _cylinder,
    _frustum,
    _mirrored,
    _moved,
    _pair,
    _Part,
    _pick,
    _revolve,
    _rod,
    _rotation,
    _sphere,
    _torus,
)

# ============================================================================ categories
#
# One builder per category: rng -> list of parts, in the canonical frame
# (+z up, +x front, mirror plane y = 0, floor at z = 0 before centring).


def _wing(
    *, x_root: float, z_root: float, chord: float, span: float, taper: float,
    sweep: float, dihedral: float, thickness: float,
) -> _Part:
    """The right (``+y``) half of a straight tapered wing as one block.

    The root lies in ``y = 0`` with its trailing edge at ``x_root`` and its
    leading edge at ``x_root + chord``; the leading edge is swept back
    (towards ``-x``) by ``sweep`` radians and the tip raised by ``dihedral``
    radians. Chord and thickness shrink by the factor ``taper`` at the tip.
    """
    tip_chord, tip_t = chord * taper, thickness * taper
    tip_x = x_root + chord - span * math.tan(sweep) - tip_chord  # trailing edge at the tip
    tip_z = z_root + span * math.tan(dihedral)
    root_low, root_high = z_root - thickness / 2, z_root + thickness / 2
    tip_low, tip_high = tip_z - tip_t / 2, tip_z + tip_t / 2
    return _block([
        [x_root, 0.0, root_low], [x_root + chord, 0.0, root_low],
        [tip_x + tip_chord, span, tip_low], [tip_x, span, tip_low],
        [x_root, 0.0, root_high], [x_root + chord, 0.0, root_high],
        [tip_x + tip_chord, span, tip_high], [tip_x, span, tip_high],
    ])


def _airplane(rng: np.random.Generator) -> list[_Part]:
    """Fuselage of revolution, swept wings, 0/2/4 engines, usually a tail fin, maybe a T-tail."""
    length = rng.uniform(12.0, 40.0)
    radius = length * rng.uniform(0.04, 0.065)
    # Fuselage profile from the tail (z = 0) to the nose (z = length), turned onto +x.
    tail_end, nose_start = length * rng.uniform(0.2, 0.3), length * rng.uniform(0.8, 0.88)
    nose = np.linspace(0.0, np.pi / 2, 6)[1:]
    profile = np.vstack([
        [[radius * 0.12, 0.0], [radius * 0.45, tail_end * 0.4], [radius * 0.85, tail_end * 0.8],
         [radius, tail_end], [radius, nose_start]],
        np.stack([radius * np.cos(nose), nose_start + (length - nose_start) * np.sin(nose)], 1),
    ])
    profile[-1, 0] = 0.0  # the nose is a pole
    fuselage = _revolve(profile, n_segments=20)
    parts = [_moved(fuselage, rotation=_Z_TO_X, offset=[-length / 2, 0.0, 0.0])]

    half_span, chord = length * rng.uniform(0.4, 0.65), length * rng.uniform(0.12, 0.22)
    taper, sweep = rng.uniform(0.25, 0.6), math.radians(rng.uniform(0.0, 35.0))
    dihedral = math.radians(rng.uniform(0.0, 6.0))
    wing_x = length * rng.uniform(-0.12, 0.02) - chord / 2
    wing_z = radius * float(rng.choice([-0.6, 0.0, 0.7], p=[0.6, 0.2, 0.2]))  # low, mid, high
    parts += _pair(_wing(x_root=wing_x, z_root=wing_z, chord=chord, span=half_span, taper=taper,
                         sweep=sweep, dihedral=dihedral, thickness=chord * 0.12))

    # Engines: 0, 2 or 4 nacelles hanging on pylons in front of the wing.
    n_engines = int(rng.choice([0, 2, 4], p=[0.25, 0.5, 0.25]))
    nacelle_r, nacelle_len = radius * rng.uniform(0.35, 0.55), chord * rng.uniform(0.7, 1.0)
    nacelle = _revolve([
        [nacelle_r * 0.6, 0.0], [nacelle_r, nacelle_len * 0.25],
        [nacelle_r * 0.95, nacelle_len * 0.85], [nacelle_r * 0.75, nacelle_len],
    ], n_segments=16)
    nacelle = _moved(nacelle, rotation=_Z_TO_X)
    for fraction in {0: [], 2: [0.35], 4: [0.3, 0.6]}[n_engines]:
        y = half_span * fraction
        leading_x = wing_x + chord - y * math.tan(sweep)
        z = wing_z + y * math.tan(dihedral) - nacelle_r * 1.6
        parts += _pair(_moved(nacelle, offset=[leading_x - nacelle_len * 0.45, y, z]))
        parts += _pair(_centred_box([leading_x - nacelle_len * 0.15, y, z + nacelle_r],
                                    [nacelle_len * 0.5, nacelle_r * 0.25, nacelle_r * 1.6]))

    # Tail: a swept vertical fin (most airplanes), stabilisers low or on top of the fin.
    fin_x = -length / 2 + length * rng.uniform(0.01, 0.05)  # trailing edge of the fin root
    fin_chord, fin_height = length * rng.uniform(0.12, 0.2), radius * rng.uniform(2.0, 3.5)
    fin_taper = rng.uniform(0.35, 0.7)
    fin_tip_x = fin_x + fin_chord * (1.0 - fin_taper) * rng.uniform(0.2, 1.3)  # tip trailing edge
    fin_tip_chord = fin_chord * fin_taper
    has_fin = rng.random() < 0.85
    if has_fin:
        t = fin_chord * 0.1
        parts.append(_block([
            [fin_x, -t / 2, 0.0], [fin_x + fin_chord, -t / 2, 0.0],
            [fin_x + fin_chord, t / 2, 0.0], [fin_x, t / 2, 0.0],
            [fin_tip_x, -t / 4, fin_height], [fin_tip_x + fin_tip_chord, -t / 4, fin_height],
            [fin_tip_x + fin_tip_chord, t / 4, fin_height], [fin_tip_x, t / 4, fin_height],
        ]))
    is_t_tail = has_fin and rng.random() < 0.2
    stab_chord = fin_chord * rng.uniform(0.7, 1.0) * (fin_taper if is_t_tail else 1.0)
    parts += _pair(_wing(
        x_root=fin_tip_x if is_t_tail else fin_x,
        z_root=fin_height if is_t_tail else radius * rng.uniform(-0.1, 0.4),
        chord=stab_chord, span=half_span * rng.uniform(0.28, 0.4), taper=rng.uniform(0.4, 0.7),
        sweep=sweep, dihedral=dihedral, thickness=stab_chord * 0.1,
    ))
    return parts


def _bench(rng: np.random.Generator) -> list[_Part]:
    """Long low seat (slab or slats) on legs, end panels or A-frames, maybe a backrest and arms."""
    length, depth = rng.uniform(1.2, 2.2), rng.uniform(0.32, 0.5)
    seat_z, thickness = rng.uniform(0.4, 0.48), rng.uniform(0.04, 0.07)
    under, half_y = seat_z - thickness, length / 2
    parts: list[_Part] = []
    if rng.random() < 0.5:
        parts.append(_box([-depth / 2, -half_y, under], [depth / 2, half_y, seat_z]))
    else:
        n_slats = int(rng.integers(3, 6))
        gap = depth * rng.uniform(0.03, 0.08)
        slat = (depth - (n_slats - 1) * gap) / n_slats
        for k in range(n_slats):
            x0 = -depth / 2 + k * (slat + gap)
            parts.append(_box([x0, -half_y, under], [x0 + slat, half_y, seat_z]))

    end_y = half_y - rng.uniform(0.03, 0.15)  # outer face of the supports at either end
    support = _pick(rng, ["legs", "panels", "a_frame"], [0.45, 0.3, 0.25])
    if support == "legs":  # four legs, six on long benches
        leg = rng.uniform(0.04, 0.07)
        leg_x = depth / 2 - leg / 2 - rng.uniform(0.0, 0.05)
        for x in (-leg_x, leg_x):
            parts += _pair(_centred_box([x, end_y - leg / 2, under / 2], [leg, leg, under]))
            if length > 1.7:
                parts.append(_centred_box([x, 0.0, under / 2], [leg, leg, under]))
    elif support == "panels":
        panel = rng.uniform(0.04, 0.08)
        parts += _pair(_box([-depth * 0.45, end_y - panel, 0.0], [depth * 0.45, end_y, under]))
    else:  # an A-frame of two slanted bars at each end, with a cross bar
        bar, splay = rng.uniform(0.04, 0.06), rng.uniform(0.0, 0.08)
        for side in (-1.0, 1.0):
            foot, head = side * (depth / 2 + splay - bar), side * depth / 4
            foot_low, foot_high = sorted([foot, foot + side * bar])
            head_low, head_high = sorted([head, head + side * bar])
            parts += _pair(_block([
                [foot_low, end_y - bar, 0.0], [foot_high, end_y - bar, 0.0],
                [foot_high, end_y, 0.0], [foot_low, end_y, 0.0],
                [head_low, end_y - bar, under], [head_high, end_y - bar, under],
                [head_high, end_y, under], [head_low, end_y, under],
            ]))
        parts += _pair(_centred_box([0.0, end_y - bar / 2, under * 0.35], [depth * 0.8, bar, bar]))

    if rng.random() < 0.35:  # a backrest: two tilted posts and 1-3 rails
        back_h, post = rng.uniform(0.3, 0.42), rng.uniform(0.04, 0.06)
        tilt = _rotation("y", -math.radians(rng.uniform(0.0, 15.0)))
        back_x = -depth / 2 + post / 2
        post_part = _centred_box([0.0, 0.0, back_h / 2], [post, post, back_h])
        parts += _pair(_moved(post_part, rotation=tilt, offset=[back_x, end_y - post / 2, seat_z]))
        n_rails = int(rng.integers(1, 4))
        rail_h = back_h * 0.7 / n_rails
        for k in range(n_rails):
            z_mid = back_h * 0.85 - k * back_h * 0.8 / n_rails - rail_h / 2
            rail = _centred_box([0.0, 0.0, z_mid], [post * 0.6, length * 0.98, rail_h * 0.8])
            parts.append(_moved(rail, rotation=tilt, offset=[back_x, 0.0, seat_z]))
        if rng.random() < 0.5:  # armrests: a post and a rest at each end
            arm_h, arm_y = rng.uniform(0.18, 0.25), half_y - 0.03
            parts += _pair(_centred_box([depth * 0.3, arm_y, seat_z + arm_h / 2],
                                        [0.04, 0.04, arm_h]))
            parts += _pair(_centred_box([0.0, arm_y, seat_z + arm_h], [depth * 0.9, 0.06, 0.035]))
    return parts


def _bottle(rng: np.random.Generator) -> list[_Part]:
    """One surface of revolution (body, shoulder, neck, lip, maybe a cap), maybe a handle."""
    radius = rng.uniform(0.03, 0.055)
    body_h = radius * rng.uniform(3.0, 5.5)
    shoulder_h = radius * rng.uniform(0.4, 1.6)
    neck_r = radius * rng.uniform(0.22, 0.45)
    neck_h = radius * rng.uniform(0.6, 2.6)
    waist = rng.uniform(0.82, 0.95) if rng.random() < 0.3 else 1.0
    body_z = np.linspace(0.08 * radius, body_h, 5)
    body_r = radius * (1.0 - (1.0 - waist) * np.sin(np.linspace(0.0, np.pi, 5)))
    t = np.linspace(0.0, 1.0, 9)[1:]
    shoulder_r = neck_r + (radius - neck_r) * (1 + np.cos(np.pi * t)) / 2
    top, lip, lip_r = body_h + shoulder_h + neck_h, radius * 0.08, neck_r * 1.18
    profile: list[ArrayLike] = [
        [[radius * 0.9, 0.0]],  # a chamfered bottom edge
        np.stack([body_r, body_z], axis=1),
        np.stack([shoulder_r, body_h + shoulder_h * t], axis=1),
        [[neck_r, top - lip], [lip_r, top - lip], [lip_r, top - lip * 0.3], [neck_r, top]],
    ]
    if rng.random() < 0.4:  # a screw cap on top of the neck
        cap_r, cap_h = neck_r * rng.uniform(1.1, 1.3), radius * rng.uniform(0.3, 0.8)
        profile.append([[cap_r, top], [cap_r, top + cap_h]])
    parts = [_revolve(np.vstack(profile), n_segments=32)]
    if rng.random() < 0.2:  # an upright oval handle in the xz plane, half inside the body
        major, minor = radius * rng.uniform(0.4, 0.55), radius * rng.uniform(0.1, 0.16)
        stretch = rng.uniform(1.4, 2.2)  # taller than wide
        handle_z = body_h * rng.uniform(0.5, 0.7)
        parts.append(_moved(_torus(major, minor, n_major=20, n_minor=8), scale=[1.0, stretch, 1.0],
                            rotation=_rotation("x", np.pi / 2), offset=[radius, 0.0, handle_z]))
    return parts


def _car(rng: np.random.Generator) -> list[_Part]:
    """Slanted lower body, tapered cabin by body type, four wheels, maybe mirrors and spoiler."""
    kind = _pick(rng, ["sedan", "hatchback", "suv", "pickup", "coupe"],
                 [0.3, 0.2, 0.2, 0.15, 0.15])
    is_tall = kind in ("suv", "pickup")
    length, width = rng.uniform(3.6, 5.0), rng.uniform(1.65, 2.0)
    wheel_r = rng.uniform(0.3, 0.38) * (1.15 if is_tall else 1.0)
    clearance = wheel_r * rng.uniform(0.45, 0.65)
    belt = clearance + rng.uniform(0.5, 0.65) * (1.15 if is_tall else 1.0)
    roof = belt + rng.uniform(0.4, 0.55) * (0.85 if kind == "coupe" else 1.0)
    x0, x1, y = -length / 2, length / 2, width / 2
    nose, tail = length * rng.uniform(0.03, 0.07), length * rng.uniform(0.02, 0.05)
    parts = [_block([
        [x0 + tail, -y, clearance], [x1 - nose, -y, clearance],
        [x1 - nose, y, clearance], [x0 + tail, y, clearance],
        [x0, -y, belt], [x1, -y, belt], [x1, y, belt], [x0, y, belt],
    ])]
    # Cabin: from cabin_x0 to cabin_x1 at the belt line, the narrower roof set back at both ends.
    front = {"sedan": 0.3, "hatchback": 0.25, "suv": 0.27, "pickup": 0.3, "coupe": 0.25}[kind]
    rear = {"sedan": 0.22, "hatchback": 0.02, "suv": 0.02, "pickup": 0.45, "coupe": 0.2}[kind]
    cabin_x1 = x1 - length * (front + rng.uniform(-0.03, 0.03))
    cabin_x0 = x0 + length * (rear + rng.uniform(0.0, 0.03))
    cabin_len = cabin_x1 - cabin_x0
    roof_x1 = cabin_x1 - cabin_len * rng.uniform(0.22, 0.35)  # windscreen slope
    rear_slope = rng.uniform(0.02, 0.08) if kind in ("hatchback", "suv", "pickup") \
        else rng.uniform(0.15, 0.3)
    roof_x0 = cabin_x0 + cabin_len * rear_slope
    cabin_y, roof_y = y * 0.97, y * rng.uniform(0.78, 0.9)
    parts.append(_block([
        [cabin_x0, -cabin_y, belt], [cabin_x1, -cabin_y, belt],
        [cabin_x1, cabin_y, belt], [cabin_x0, cabin_y, belt],
        [roof_x0, -roof_y, roof], [roof_x1, -roof_y, roof],
        [roof_x1, roof_y, roof], [roof_x0, roof_y, roof],
    ]))
    # Wheels: tyres with rounded edges, axis along y, mirrored across y = 0.
    tyre_w = rng.uniform(0.18, 0.26)
    tyre = [[wheel_r * 0.7, -tyre_w / 2], [wheel_r * 0.95, -tyre_w / 2],
            [wheel_r, -tyre_w * 0.3], [wheel_r, tyre_w * 0.3],
            [wheel_r * 0.95, tyre_w / 2], [wheel_r * 0.7, tyre_w / 2]]
    wheel = _moved(_revolve(tyre, n_segments=20), rotation=_Z_TO_Y)
    wheel_front = x1 - length * rng.uniform(0.17, 0.23)
    wheel_rear = x0 + length * rng.uniform(0.17, 0.25)
    for x in (wheel_front, wheel_rear):
        parts += _pair(_moved(wheel, offset=[x, y - tyre_w * 0.4, wheel_r]))
    if rng.random() < 0.6:  # side mirrors
        parts += _pair(_centred_box([cabin_x1 - 0.1, y + 0.06, belt + 0.12], [0.1, 0.14, 0.1]))
    if kind != "pickup" and rng.random() < 0.25:  # a rear spoiler on two posts
        spoiler_z = belt + rng.uniform(0.12, 0.25)
        parts.append(_box([x0 + 0.02, -y * 0.85, spoiler_z],
                          [x0 + 0.3, y * 0.85, spoiler_z + 0.04]))
        parts += _pair(_centred_box([x0 + 0.16, y * 0.6, (belt + spoiler_z) / 2 + 0.01],
                                    [0.08, 0.05, spoiler_z - belt + 0.02]))
    if kind == "suv" and rng.random() < 0.5:  # roof rails
        parts += _pair(_box([roof_x0 + 0.05, roof_y * 0.8, roof],
                            [roof_x1 - 0.05, roof_y * 0.9, roof + 0.06]))
    return parts


def _chair(rng: np.random.Generator) -> list[_Part]:
    """Seat on four legs, swivel base or sled; solid, slatted or framed back; maybe arms."""
    seat_z, thickness = rng.uniform(0.4, 0.5), rng.uniform(0.03, 0.08)
    width, depth = rng.uniform(0.4, 0.56), rng.uniform(0.38, 0.52)
    under = seat_z - thickness
    parts = [_box([-depth / 2, -width / 2, under], [depth / 2, width / 2, seat_z])]
    base = _pick(rng, ["legs", "swivel", "sled"], [0.65, 0.25, 0.1])
    if base == "legs":
        leg, inset = rng.uniform(0.025, 0.05), rng.uniform(0.0, 0.04)
        leg_x, leg_y = depth / 2 - inset - leg / 2, width / 2 - inset - leg / 2
        if rng.random() < 0.4:  # round legs, maybe tapered towards the floor
            leg_part = _frustum(leg / 2 * rng.uniform(0.6, 1.0), leg / 2, 0.0, under, n_segments=12)
        else:
            leg_part = _centred_box([0.0, 0.0, under / 2], [leg, leg, under])
        for x in (-leg_x, leg_x):
            parts += _pair(_moved(leg_part, offset=[x, leg_y, 0.0]))
        if rng.random() < 0.4:  # side stretchers
            stretcher = _centred_box([0.0, leg_y, under * 0.3], [2 * leg_x, leg * 0.6, leg * 0.6])
            parts += _pair(stretcher)
    elif base == "swivel":  # gas column, hub, five spokes with casters
        column_r = rng.uniform(0.022, 0.035)
        hub_z, spoke_len = rng.uniform(0.06, 0.1), rng.uniform(0.24, 0.32)
        parts.append(_cylinder(column_r, hub_z, under))
        parts.append(_cylinder(column_r * 1.8, hub_z - 0.03, hub_z + 0.03))
        spoke = _box([0.0, -0.02, hub_z - 0.02], [spoke_len, 0.02, hub_z + 0.02])
        caster = _moved(_sphere(0.025, n_segments=12), offset=[spoke_len - 0.02, 0.0, 0.025])
        for k in range(5):
            turn = _rotation("z", 2 * np.pi * k / 5)
            parts += [_moved(spoke, rotation=turn), _moved(caster, rotation=turn)]
    else:  # sled: a runner on the floor and two uprights on each side
        bar = rng.uniform(0.015, 0.025)
        runner_y = width / 2 - bar
        parts += _pair(_rod([-depth / 2, runner_y, bar], [depth / 2, runner_y, bar], bar))
        for x in (-depth / 2 + bar, depth / 2 - bar):
            parts += _pair(_rod([x, runner_y, bar], [x * 0.9, runner_y, under], bar))

    back_h, back_t = rng.uniform(0.3, 0.55), rng.uniform(0.02, 0.06)
    tilt = _rotation("y", -math.radians(rng.uniform(0.0, 15.0)))
    style = _pick(rng, ["solid", "slats", "frame"], [0.5, 0.25, 0.25])
    back_parts: list[_Part] = []  # built upright at the origin, then tilted and moved
    if style == "solid":
        back_parts.append(_centred_box([0.0, 0.0, back_h / 2], [back_t, width, back_h]))
    else:  # two posts and a top rail, with vertical slats or a middle rail
        post = rng.uniform(0.025, 0.045)
        rail_h = back_h * rng.uniform(0.12, 0.3)
        back_parts += _pair(_centred_box([0.0, width / 2 - post / 2, back_h / 2],
                                         [back_t, post, back_h]))
        back_parts.append(_centred_box([0.0, 0.0, back_h - rail_h / 2], [back_t, width, rail_h]))
        if style == "slats":
            n_slats = int(rng.integers(2, 6))
            for y in np.linspace(-width / 2 + post, width / 2 - post, n_slats + 2)[1:-1]:
                back_parts.append(_centred_box([0.0, y, (back_h - rail_h) / 2],
                                               [back_t * 0.6, post * 0.6, back_h - rail_h]))
        else:
            middle_rail = _centred_box([0.0, 0.0, back_h * 0.35], [back_t, width, rail_h * 0.6])
            back_parts.append(middle_rail)
    anchor = [-depth / 2 + back_t / 2, 0.0, seat_z]
    parts += [_moved(part, rotation=tilt, offset=anchor) for part in back_parts]

    if rng.random() < 0.35:  # armrests: a post at the front and a rest along the side
        arm_h, arm_w = rng.uniform(0.17, 0.25), rng.uniform(0.04, 0.07)
        arm_y = width / 2 + arm_w / 2 * rng.uniform(-1.0, 1.0)
        parts += _pair(_centred_box([depth * 0.35, arm_y, seat_z + arm_h / 2],
                                    [arm_w * 0.6, arm_w * 0.6, arm_h]))
        parts += _pair(_centred_box([0.0, arm_y, seat_z + arm_h], [depth * 0.95, arm_w, 0.03]))
    return parts


def _sofa(rng: np.random.Generator) -> list[_Part]:
    """Base, 1-4 seat cushions, thick back, usually arms (flat or rolled), legs, rarely a chaise."""
    length, depth = rng.uniform(1.3, 2.5), rng.uniform(0.8, 1.0)
    seat_z, cushion_t = rng.uniform(0.38, 0.48), rng.uniform(0.1, 0.18)
    leg_h = rng.uniform(0.05, 0.15) if rng.random() < 0.7 else 0.0
    back_t, back_z = rng.uniform(0.15, 0.25), rng.uniform(0.75, 1.0)
    has_arms = rng.random() < 0.9
    arm_w = rng.uniform(0.1, 0.25) if has_arms else 0.0
    x0, x1, y = -depth / 2, depth / 2, length / 2
    parts = [
        _box([x0, -y, leg_h], [x1, y, seat_z - cushion_t]),  # base
        _box([x0, -y + arm_w, leg_h], [x0 + back_t, y - arm_w, back_z]),  # back
    ]
    inner = length - 2 * arm_w
    n_seats = int(np.clip(round(inner / 0.6), 1, 4))
    seat_w = inner / n_seats
    has_back_cushions = rng.random() < 0.5
    lean = _rotation("y", -math.radians(rng.uniform(5.0, 15.0)))
    back_cushion = _box([0.0, 0.005, 0.0], [cushion_t, seat_w - 0.005, (back_z - seat_z) * 0.85])
    for k in range(n_seats):
        y0 = -inner / 2 + k * seat_w
        parts.append(_box([x0 + back_t, y0 + 0.005, seat_z - cushion_t - 0.01],
                          [x1, y0 + seat_w - 0.005, seat_z]))
        if has_back_cushions:  # leaning against the back
            parts.append(_moved(back_cushion, rotation=lean, offset=[x0 + back_t, y0, seat_z]))
    if has_arms:
        arm_z = rng.uniform(0.55, 0.7)
        parts += _pair(_box([x0, y - arm_w, leg_h], [x1, y, arm_z]))
        if rng.random() < 0.4:  # rolled arms
            roll = _cylinder(arm_w / 2 * 1.1, x0, x1, n_segments=16)
            parts += _pair(_moved(roll, rotation=_Z_TO_X, offset=[0.0, y - arm_w / 2, arm_z]))
    if leg_h > 0:
        leg = _frustum(rng.uniform(0.014, 0.025), rng.uniform(0.02, 0.035), 0.0, leg_h + 0.01,
                       n_segments=12)
        for x in (x0 + 0.06, x1 - 0.06):
            parts += _pair(_moved(leg, offset=[x, y - 0.06, 0.0]))
    if rng.random() < 0.15:  # a chaise longue on one side: breaks the mirror symmetry
        chaise_w = min(rng.uniform(0.6, 0.8), inner / 2)
        chaise = _box([x1 - 0.05, y - arm_w - chaise_w, 0.0],
                      [x1 + rng.uniform(0.5, 0.8), y - arm_w, seat_z])
        parts.append(chaise if rng.random() < 0.5 else _mirrored(chaise))
    return parts


def _table(rng: np.random.Generator) -> list[_Part]:
    """Rectangular or round top on four legs (maybe apron, shelf), 3 legs, pedestal or trestles."""
    height = rng.uniform(0.68, 0.78) if rng.random() < 0.75 else rng.uniform(0.38, 0.5)
    under = height - rng.uniform(0.025, 0.06)
    style = _pick(rng, ["four_legs", "three_legs", "pedestal", "trestle"], [0.5, 0.15, 0.2, 0.15])
    round_chance = {"four_legs": 0.2, "three_legs": 1.0, "pedestal": 0.7, "trestle": 0.0}[style]
    is_round = rng.random() < round_chance
    radius = rng.uniform(0.4, 0.7)
    length = rng.uniform(0.9, 2.0)
    width = rng.uniform(0.55, min(1.1, length))
    if style == "pedestal" and not is_round:  # a square top
        length = width = rng.uniform(0.6, 1.0)
    if is_round:
        parts = [_cylinder(radius, under, height, n_segments=32)]
        half_x = half_y = radius / math.sqrt(2.0)
    else:
        parts = [_box([-length / 2, -width / 2, under], [length / 2, width / 2, height])]
        half_x, half_y = length / 2, width / 2

    if style == "four_legs":
        leg, inset = rng.uniform(0.035, 0.08), rng.uniform(0.0, 0.1)
        leg_x, leg_y = half_x - inset - leg / 2, half_y - inset - leg / 2
        shape = _pick(rng, ["square", "round", "tapered"], [0.5, 0.25, 0.25])
        if shape == "square":
            leg_part = _centred_box([0.0, 0.0, under / 2], [leg, leg, under])
        else:
            foot_r = leg / 2 * (0.5 if shape == "tapered" else 1.0)
            leg_part = _frustum(foot_r, leg / 2, 0.0, under, n_segments=12)
        for x in (-leg_x, leg_x):
            parts += _pair(_moved(leg_part, offset=[x, leg_y, 0.0]))
        if rng.random() < 0.5:  # an apron under the top
            apron_h = rng.uniform(0.06, 0.12)
            z = under - apron_h / 2
            parts += _pair(_centred_box([0.0, leg_y, z], [2 * leg_x, 0.02, apron_h]))
            for x in (-leg_x, leg_x):
                parts.append(_centred_box([x, 0.0, z], [0.02, 2 * leg_y, apron_h]))
        if rng.random() < 0.2:  # a lower shelf
            z = rng.uniform(0.1, 0.25) * height
            parts.append(_centred_box([0.0, 0.0, z], [2 * leg_x + leg, 2 * leg_y + leg, 0.02]))
    elif style == "three_legs":  # at 0 and +-120 degrees, maybe splayed
        leg_r, splay = rng.uniform(0.015, 0.035), rng.uniform(0.0, 0.2) * radius
        leg_part = _rod([radius * 0.65, 0.0, under], [radius * 0.65 + splay, 0.0, 0.0], leg_r)
        for angle in (0.0, 2 * np.pi / 3, -2 * np.pi / 3):
            parts.append(_moved(leg_part, rotation=_rotation("z", angle)))
    elif style == "pedestal":  # a column, maybe bulging, on a domed disk or four feet
        column_r, bulge = rng.uniform(0.04, 0.09), rng.uniform(1.0, 1.8)
        parts.append(_revolve([[column_r, 0.02], [column_r * bulge, under * 0.3],
                               [column_r, under * 0.55], [column_r, under + 0.001]]))
        foot_span = max(half_x, half_y) * rng.uniform(0.6, 0.9)
        if rng.random() < 0.5:
            disk = [[foot_span, 0.0], [foot_span, 0.02], [foot_span * 0.3, 0.06]]
            parts.append(_revolve(disk, n_segments=32))
        else:  # on the axes or on the diagonals
            foot = _box([0.0, -0.025, 0.0], [foot_span, 0.025, 0.05])
            start = float(rng.choice([0.0, np.pi / 4]))
            for k in range(4):
                parts.append(_moved(foot, rotation=_rotation("z", start + k * np.pi / 2)))
    else:  # trestle: two end panels on feet, joined by a stretcher
        panel_t, inset = rng.uniform(0.04, 0.08), rng.uniform(0.05, 0.2)
        panel_x, panel_w = half_x - inset - panel_t / 2, width * rng.uniform(0.2, 0.6)
        for x in (-panel_x, panel_x):
            parts.append(_centred_box([x, 0.0, under / 2], [panel_t, panel_w, under]))
            parts.append(_centred_box([x, 0.0, 0.03], [panel_t * 1.5, width * 0.9, 0.06]))
        stretcher_z = under * rng.uniform(0.2, 0.6)
        parts.append(_centred_box([0.0, 0.0, stretcher_z], [2 * panel_x, 0.05, 0.08]))
    return parts


def _toilet(rng: np.random.Generator) -> list[_Part]:
    """Elongated hollow bowl, seat ring, maybe a lid (open or closed), tank, button or lever."""
    rim_z, rim_r = rng.uniform(0.36, 0.42), rng.uniform(0.17, 0.21)
    foot_r, base_r = rim_r * rng.uniform(0.45, 0.6), rim_r * rng.uniform(0.6, 0.85)
    elongation = rng.uniform(1.15, 1.45)  # the bowl is longer along x than wide
    depth = rim_z * rng.uniform(0.35, 0.55)
    rim_w = rim_r * rng.uniform(0.12, 0.2)
    inner_r = rim_r - rim_w
    bowl = _revolve([  # up the outside, over the rim and down into the cavity
        [base_r, 0.0], [foot_r, rim_z * 0.25], [foot_r * 1.1, rim_z * 0.5],
        [rim_r * 0.95, rim_z * 0.85], [rim_r, rim_z], [inner_r, rim_z],
        [inner_r * 0.6, rim_z - depth * 0.6], [inner_r * 0.3, rim_z - depth],
    ], n_segments=24)
    bowl_x = rim_r * elongation * 0.35
    parts = [_moved(bowl, scale=[elongation, 1.0, 1.0], offset=[bowl_x, 0.0, 0.0])]
    seat_t = rng.uniform(0.015, 0.03)
    ring = _torus(rim_r - rim_w / 2, rim_w * 0.6, n_minor=8)
    parts.append(_moved(ring, scale=[elongation, 1.0, seat_t / (rim_w * 1.2)],
                        offset=[bowl_x, 0.0, rim_z + seat_t / 2]))

    has_tank = rng.random() < 0.85
    tank_depth, tank_w = rng.uniform(0.15, 0.22), rng.uniform(0.35, 0.5)
    hinge_x = bowl_x - rim_r * elongation  # back of the rim
    tank_x = hinge_x - rng.uniform(0.0, 0.03)  # front face of the tank
    tank_top = rng.uniform(0.7, 0.8)
    lid = _moved(_cylinder(1.0, 0.0, 1.0, n_segments=24),
                 scale=[rim_r * elongation, rim_r, seat_t])
    lid_state = rng.random()
    if lid_state < 0.4:  # closed on the seat
        parts.append(_moved(lid, offset=[bowl_x, 0.0, rim_z + seat_t]))
    elif lid_state < 0.8:  # open, hinged at the back of the rim, leaning on the tank or wall
        lean_deg = rng.uniform(91.0, 93.0) if has_tank else rng.uniform(95.0, 110.0)
        hinged = _moved(lid, offset=[rim_r * elongation, 0.0, 0.0])
        parts.append(_moved(hinged, rotation=_rotation("y", -math.radians(lean_deg)),
                            offset=[hinge_x, 0.0, rim_z + seat_t]))
    if has_tank:
        tank_back, half_w = tank_x - tank_depth, tank_w / 2
        parts.append(_box([tank_back, -half_w, rim_z * 0.95], [tank_x, half_w, tank_top]))
        parts.append(_box([tank_back - 0.01, -half_w - 0.01, tank_top],
                          [tank_x + 0.01, half_w + 0.01, tank_top + 0.025]))  # tank lid
        parts.append(_box([tank_x - tank_depth * 0.6, -0.1, 0.05],
                          [tank_x + 0.01, 0.1, rim_z * 0.95]))  # back of the pedestal
        if rng.random() < 0.5:  # a push button on the tank lid (symmetric)
            parts.append(_cylinder(0.02, tank_top + 0.025, tank_top + 0.035, n_segments=12))
        else:  # a lever on the front face, on one side (asymmetric)
            side = 1.0 if rng.random() < 0.5 else -1.0
            parts.append(_centred_box([tank_x + 0.02, side * (half_w - 0.06), tank_top - 0.05],
                                      [0.04, 0.08, 0.015]))
    return parts


_BUILDERS: dict[str, Callable[[np.random.Generator], list[_Part]]] = {
    "airplane": _airplane,
    "bench": _bench,
    "bottle": _bottle,
    "car": _car,
    "chair": _chair,
    "sofa": _sofa,
    "table": _table,
    "toilet": _toilet,
}
