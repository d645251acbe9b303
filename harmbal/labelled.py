"""Labelled arrays at the public edge: conventions, the speed axis and the
construction of xarray objects from plain arrays (once, with final coords and attrs)."""

from __future__ import annotations

import numpy as np

from .scene import Scene


AXES = ("x", "y", "z")


CONVENTIONS = (
    "Engine frame: x along the crank axis towards the front (pulley end), y to the right seen from the "
    "front, z up; right-handed. Crank angle theta in the direction of rotation, 0 when throw 1 points along +z. "
    "force, moment: exerted by the moving parts on the block; moment about the scene's reference point. "
    "See docs/conventions.md."
)


def speed_axis(scene: Scene):
    """The scene's speeds as a leading dimension.

    Returns ``(lead, w2, coords)``: ``("speed",)`` and the array of ω² if the
    scene has several speeds, else ``()`` and the scalar ω²; and the
    ``speed`` [rad/s] and ``rpm`` coordinates.
    """
    speeds = np.asarray(scene.speeds, dtype=float)
    if len(speeds) > 1:
        lead, values = ("speed",), speeds
    else:
        lead, values = (), speeds[0]
    coords = {
        "speed": (lead, values, {"units": "rad/s", "long_name": "crank speed ω"}),
        "rpm": (lead, values * 30 / np.pi, {"units": "rpm", "long_name": "crank speed"}),
    }
    return lead, values**2, coords
