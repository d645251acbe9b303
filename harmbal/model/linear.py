"""The planar loads of a cylinder per unit of each mass property.

For a fixed geometry (crank radius, rod length, offsets, the rod's and the
piston's CG positions) the inertial loads of :func:`~.evaluate.planar_loads`
are linear in the piston mass, the rod mass and the rod's moment of inertia:
the reciprocating mass is m_piston + m_rod·a/l, the rotating one m_rod·(1 − a/l)
and the rigid rod's extra couple (I − m_rod·a·(l − a))·ϑ̈. So one evaluation of
the kinematics per geometry gives the loads of every variant that differs only
in those masses: Σ_j value_j × (load per unit of property j). A design sweep
(:mod:`harmbal.studies.sweep`) uses this to evaluate each distinct geometry once.
"""

from __future__ import annotations

import numpy as np

from ..scene import Model
from . import loads
from .kinematics import crank_pin, slider_crank

#: The mass properties the planar loads are linear in, per cylinder: piston mass [kg], rod mass [kg] and
#: the rod's moment of inertia about its CG [kg m²].
PROPERTIES = ("piston_mass", "rod_mass", "rod_inertia")


def _column(values) -> np.ndarray:
    return np.asarray(values, dtype=float)[:, None]


def planar_basis(model: Model, cylinders, psi: np.ndarray) -> np.ndarray | None:
    """Planar loads per unit of each mass property at unit speed.

    Parameters
    ----------
    model : Model
        The scene's effects and model options (as :func:`~.evaluate.planar_loads`).
    cylinders : sequence of Cylinder
        Geometry of each row of ``psi``; their masses are not read.
    psi : ndarray
        Local crank angles ψ [rad], shape (cylinder, angle).

    Returns
    -------
    ndarray or None
        Shape (property, 3, cylinder, angle): force along and across the
        cylinder axis [N] and roll moment [N m] (with the drive torque's
        reaction if ``mass_torque`` is simulated) per kg of piston, per kg of
        rod and per kg m² of rod inertia (:data:`PROPERTIES`); the loads of a
        cylinder are Σ_j property_j × basis[j]. None if no planar effect is
        simulated.
    """
    effects = model.effects
    if not effects & {"reciprocating", "rotating", "rod_inertia"}:
        return None
    r = _column([c.crank_radius for c in cylinders])
    l = _column([c.rod_length for c in cylinders])
    rod_cg = _column([c.rod.cg_from_big_end for c in cylinders])
    small_end = rod_cg / l  # the rod's share at the piston pin, per kg of rod
    shape = np.shape(psi)
    zero = loads.PlanarLoad(*(np.zeros(shape),) * 5)
    piston = rod = inertia = zero

    def add(p, q, scale=1.0):
        return loads.PlanarLoad(*(a + scale * b for a, b in zip(
            (p.force_c, p.force_n, p.roll, p.power, p.energy), (q.force_c, q.force_n, q.roll, q.power, q.energy))))

    kin = None
    if effects & {"reciprocating", "rod_inertia"}:
        series = model.series_harmonics if model.piston == "series" else None
        kin = slider_crank(psi, r, l, _column([c.offset for c in cylinders]), series)
    if "reciprocating" in effects:
        assert kin is not None  # made above for these effects
        piston = add(piston, loads.reciprocating(kin, 1.0, _column([c.piston.cg_lateral for c in cylinders]), 0.0))
        # 1 kg on the pin axis (no lateral CG), times the rod's share there.
        rod = add(rod, loads.reciprocating(kin, 1.0, 0.0, 0.0), small_end)
    if "rotating" in effects:
        pin, _, _ = crank_pin(psi, r)
        rod = add(rod, loads.rotating_rod(pin, 1.0), 1.0 - small_end)
    if "rod_inertia" in effects and model.rod != "two_point":
        lateral = _column([c.rod.cg_lateral for c in cylinders])
        off_axis = model.rod == "rigid" and bool(np.any(lateral))
        assert kin is not None
        rod = add(rod, loads.rod_inertia(kin, 1.0, rod_cg, lateral, 0.0, l, off_axis))
        inertia = add(inertia, loads.rod_inertia(kin, 0.0, rod_cg, lateral, 1.0, l, False))
    basis = []
    for part in (piston, rod, inertia):
        roll = part.roll + part.power if "mass_torque" in effects else part.roll
        basis.append(np.stack([part.force_c, part.force_n, roll]))
    return np.stack(basis)
