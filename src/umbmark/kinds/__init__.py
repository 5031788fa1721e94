"""The kinds of robot umbmark calibrates, one module each, and their registry.

* :mod:`~umbmark.kinds.diff_drive`: the differential drive (the default kind);
* :mod:`~umbmark.kinds.tricycle`: the tricycle (``tricycle_controller``);
* :mod:`~umbmark.kinds.mecanum`: the mecanum robot (``mecanum_drive_controller``);
* :mod:`~umbmark.kinds.bicycle`: the car of the bicycle model (``bicycle_steering_controller``,
  F1TENTH's and MuSHR's ``vesc_to_odom``);
* :mod:`~umbmark.kinds.ackermann`: the Ackermann car (``ackermann_steering_controller``).

Each module holds its geometry (the forward kinematics as its ros2 controller computes them)
and a :class:`~umbmark.kinds._base.Kind` that describes it to the rest of the package: its
parameters and their JSON keys, the nominal sizes and joints the command line gives, the
self-calibration's advice, the exports, the table's legend, the random robots of the studies.
The rest of the package asks the kind (:func:`kind_named`, :func:`kind_of`) and never compares
a kind's name. The command line's choices (``--kinematics``, the kinds' own options, the export
formats) are made from :data:`KINDS`.

To add a kind: write its module (a geometry class and ``KIND``), append it to ``_MODULES``
below, give it its tests and a docs page (see the developers' page of the documentation).

Imports numpy and :mod:`umbmark.model`: the layer above the model, below every layer that uses
a kind.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

from umbmark.errors import InputError
from umbmark.kinds import ackermann, bicycle, diff_drive, mecanum, tricycle
from umbmark.kinds._base import Alternative, EditedFile, FitOption, JointOption, Kind, Parameter, Reading, Size
from umbmark.kinds.ackermann import Ackermann
from umbmark.kinds.bicycle import Bicycle
from umbmark.kinds.diff_drive import DiffDrive
from umbmark.kinds.mecanum import Mecanum
from umbmark.kinds.tricycle import Tricycle
from umbmark.model.geometry import QUANTITIES, Quantity
from umbmark.model.kinematics import Kinematics

__all__ = [
    "KINDS",
    "DEFAULT_KIND",
    "Kind",
    "Parameter",
    "Size",
    "Alternative",
    "JointOption",
    "FitOption",
    "Reading",
    "EditedFile",
    "DiffDrive",
    "Tricycle",
    "Mecanum",
    "Bicycle",
    "Ackermann",
    "kind_named",
    "kind_of",
    "kind_in",
    "kinds_with",
    "quantity_named",
    "joint_flags_for",
]

# the kinds' modules, in the order the command line lists them (append a new kind at the end:
# the studies' random robots are seeded by their kind's place among the drawable ones)
_MODULES = (diff_drive, tricycle, mecanum, bicycle, ackermann)

_REGISTRY: dict[str, Kind] = {m.KIND.name: m.KIND for m in _MODULES}
KINDS: Mapping[str, Kind] = MappingProxyType(_REGISTRY)
"""Every kind of robot by name (the command line's choices of a kind, in this order): a read-only
view of the registry."""

DEFAULT_KIND: str = diff_drive.KIND.name
"""The kind a command reads when none is named: the differential drive."""


def kind_named(name: str) -> Kind:
    """The kind of robot of a name.

    Raises
    ------
    InputError
        An unknown name (the known ones named).
    """
    try:
        return KINDS[name]
    except (KeyError, TypeError):
        raise InputError(f"unknown kinematics {name!r} (choose from {', '.join(KINDS)})") from None


def kind_of(geometry: Kinematics) -> Kind:
    """The kind of a geometry (its ``kind``).

    Raises
    ------
    InputError
        A geometry of no known kind.
    """
    return kind_named(getattr(geometry, "kind", None))  # type: ignore[arg-type]


def kind_in(d: Any) -> Kind | None:
    """The kind a result's JSON names (its ``kinematics``) when it is a kind of its own (not calibrated
    by the differential drive's pipeline), else None (a differential drive's result, or no result)."""
    name = d.get("kinematics") if isinstance(d, Mapping) else None
    k = KINDS.get(name) if isinstance(name, str) else None
    return None if k is None or k.differential else k


def kinds_with(option: str) -> tuple[Kind, ...]:
    """The kinds that have an option of their own (:meth:`~umbmark.kinds._base.Kind.option_names`)."""
    return tuple(k for k in KINDS.values() if option in k.option_names())


def quantity_named(name: str) -> Quantity:
    """A size's :class:`~umbmark.model.geometry.Quantity` by name: the built-in ones (a wheel's
    diameter and radius, the wheelbase) and every kind's own (a mecanum robot's ``lx_plus_ly``).

    Raises
    ------
    InputError
        An unknown name.
    """
    if name in QUANTITIES:
        return QUANTITIES[name]
    for k in KINDS.values():
        for s in k.sizes:
            if s.quantity.name == name:
                return s.quantity
    raise InputError(f"unknown size {name!r}")


def joint_flags_for(names: Sequence[str]) -> list[tuple[Kind, str, bool]]:
    """How each kind's options would name the joints of a JointState topic (``umbmark bag-info``).

    Parameters
    ----------
    names : sequence of str
        The topic's joint names, in the messages' order.

    Returns
    -------
    list of tuple
        For each kind with no more joints than the topic has, in the registry's order: the kind,
        its options naming the joints in the order they want them (:meth:`Kind.joint_flags`:
        the names their words fit, :meth:`Kind.guess_joints`; else the options' placeholders),
        and whether the names were found.
    """
    out = []
    for k in KINDS.values():
        if len(k.geometry.joint_roles) <= len(names):
            guess = k.guess_joints(names)
            out.append((k, k.joint_flags(guess), guess is not None))
    return out
