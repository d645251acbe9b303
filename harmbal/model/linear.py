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

from dataclasses import dataclass

import numpy as np

from ..scene import Model
from . import loads
from .kinematics import crank_pin, slider_crank

#: The mass properties the planar loads are linear in, per cylinder: piston mass [kg], rod mass [kg] and
#: the rod's moment of inertia about its CG [kg m²].
PROPERTIES = ("piston_mass", "rod_mass", "rod_inertia")


@dataclass(frozen=True)
class CylinderGeometry:
    """What fixes a cylinder's loads per unit mass, as arrays that broadcast
    against the crank angles ψ (one row per cylinder, or per variant and
    cylinder: the rows of a block of geometry variants are evaluated in one
    array pass).

    Attributes
    ----------
    crank_radius, rod_length : ndarray
        r, l [m].
    offset : ndarray
        Total offset of the piston-pin path from the crank axis [m]
        (pin offset + cylinder offset).
    piston_lateral : ndarray
        The piston CG's offset across the pin path [m].
    rod_cg, rod_lateral : ndarray
        The rod CG's distance from the big end along the rod axis and its
        distance from that axis [m].
    """

    crank_radius: np.ndarray
    rod_length: np.ndarray
    offset: np.ndarray
    piston_lateral: np.ndarray
    rod_cg: np.ndarray
    rod_lateral: np.ndarray

    @classmethod
    def of(cls, cylinders) -> CylinderGeometry:
        """Columns (cylinder, 1) of a sequence of :class:`~harmbal.scene.Cylinder`."""
        def column(values) -> np.ndarray:
            return np.asarray(values, dtype=float)[:, None]

        return cls(column([c.crank_radius for c in cylinders]), column([c.rod_length for c in cylinders]),
                   column([c.offset for c in cylinders]), column([c.piston.cg_lateral for c in cylinders]),
                   column([c.rod.cg_from_big_end for c in cylinders]), column([c.rod.cg_lateral for c in cylinders]))


def planar_basis(model: Model, cylinders, psi: np.ndarray) -> np.ndarray | None:
    """Planar loads per unit of each mass property at unit speed.

    Parameters
    ----------
    model : Model
        The scene's effects and model options (as :func:`~.evaluate.planar_loads`).
    cylinders : sequence of Cylinder or CylinderGeometry
        Geometry of each row of ``psi`` (their masses are not read), or
        the geometry as columns (:class:`CylinderGeometry`): a block of
        geometry variants is then one array pass.
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
    g = cylinders if isinstance(cylinders, CylinderGeometry) else CylinderGeometry.of(cylinders)
    r, l, rod_cg = g.crank_radius, g.rod_length, g.rod_cg
    small_end = rod_cg / l  # the rod's share at the piston pin, per kg of rod
    # ψ may be one row for every geometry: the loads broadcast to (row, angle), the trigonometry stays one row.
    shape = np.broadcast_shapes(np.shape(psi), np.shape(r))
    sums = [_Sum(), _Sum(), _Sum()]  # per property
    kin = None
    if effects & {"reciprocating", "rod_inertia"}:
        series = model.series_harmonics if model.piston == "series" else None
        kin = slider_crank(psi, r, l, g.offset, series)
    if "reciprocating" in effects:
        assert kin is not None  # made above for these effects
        on_axis = loads.reciprocating(kin, 1.0, 0.0, 0.0)
        # The piston's lateral CG changes its roll moment only: the same load where every piston is on its pin axis.
        sums[0].add(loads.reciprocating(kin, 1.0, g.piston_lateral, 0.0) if np.any(g.piston_lateral) else on_axis)
        # 1 kg on the pin axis (no lateral CG), times the rod's share there.
        sums[1].add(on_axis, small_end)
    if "rotating" in effects:
        # The crank pin is the slider-crank's A when it was made; the big end's load is radial (no roll, no power),
        # so only its forces are added: the same sums as of loads.rotating_rod(pin, 1.0), without its zeros.
        pin = kin.a if kin is not None else crank_pin(psi, r)[0]
        rotating = 1.0 - small_end
        sums[1].add_forces(rotating * pin[0], rotating * pin[1])
    if "rod_inertia" in effects and model.rod != "two_point":
        lateral = g.rod_lateral
        off_axis = model.rod == "rigid" and bool(np.any(lateral))
        assert kin is not None
        sums[1].add(loads.rod_inertia(kin, 1.0, rod_cg, lateral, 0.0, l, off_axis))
        sums[2].add(loads.rod_inertia(kin, 0.0, rod_cg, lateral, 1.0, l, False))
    basis = np.zeros((len(PROPERTIES), 3) + shape)
    for part, total in zip(basis, sums):
        total.into(part, "mass_torque" in effects)
    return basis


class _Sum:
    """A sum of planar loads (times a factor each), of the parts the basis
    needs: the forces, the roll moment and the power (the drive torque's
    reaction); the first term is taken as it is, not added to zeros."""

    def __init__(self) -> None:
        self.parts: list[np.ndarray | None] = [None] * 4

    def add(self, load: loads.PlanarLoad, scale=None) -> None:
        for i, values in enumerate((load.force_c, load.force_n, load.roll, load.power)):
            term = values if scale is None else scale * values
            self.parts[i] = term if self.parts[i] is None else self.parts[i] + term

    def add_forces(self, force_c: np.ndarray, force_n: np.ndarray) -> None:
        """Add a load that has forces alone (no roll moment, no power), already scaled."""
        for i, term in enumerate((force_c, force_n)):
            self.parts[i] = term if self.parts[i] is None else self.parts[i] + term

    def into(self, out: np.ndarray, mass_torque: bool) -> None:
        """Write the force along and across the axis and the roll moment (with the power if ``mass_torque``) into
        ``out`` (3, row, angle)."""
        force_c, force_n, roll, power = self.parts
        if roll is not None and mass_torque and power is not None:
            np.add(roll, power, out=out[2])
            roll = None
        for i, values in enumerate((force_c, force_n, roll)):
            if values is not None:
                out[i] = values
