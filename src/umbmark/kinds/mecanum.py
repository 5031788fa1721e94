"""The mecanum robot (ros2 ``mecanum_drive_controller``): four wheels with rollers at 45 deg.

Joints ``(front_left, front_right, rear_left, rear_right)``: with ``u_i = r_i dphi_i`` and
``k = l_x + l_y`` (the controller's ``sum_of_robot_center_projection_on_X_Y_axis``)::

    v_x   = ( u_FL + u_FR + u_RL + u_RR) / 4
    v_y   = (-u_FL + u_FR + u_RL - u_RR) / 4
    omega = (-u_FL + u_FR - u_RL + u_RR) / (4 k)

(the controller's forward kinematics with a radius per wheel; a bigger front-right wheel drifts
the robot left and turns it left).

Its parameters: the four wheels' diameters and ``lx + ly`` (a size of its own, half the
wheelbase plus half the track: :data:`LX_PLUS_LY`). The controller has one radius for all
wheels (``kinematics.wheels_radius``, their mean): where the four diameters differ beyond their
95 % intervals the parameter file says so and gives each wheel's factor ``r_i / r_mean``, applied
by dividing that wheel's transmission ``mechanical_reduction`` by it.

Imports numpy, :mod:`umbmark.model` and :mod:`umbmark.kinds._base`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark.errors import InputError
from umbmark.kinds._base import (
    Alternative,
    Coverage,
    Interval,
    JointOption,
    Kind,
    Parameter,
    Size,
    Uniform,
    positive_parameter,
)
from umbmark.model.geometry import QUANTITIES, ROBOT_SIZES_M, Quantity
from umbmark.model.kinematics import Kinematics

__all__ = ["Mecanum", "KIND", "LX_PLUS_LY", "ROLES", "wheel_factors"]

FloatArray = NDArray[np.float64]

ROLES = ("front_left", "front_right", "rear_left", "rear_right")
"""The wheels, in the joints' order."""

LX_PLUS_LY = Quantity(
    "lx_plus_ly",
    "mecanum robot's lx + ly",
    ROBOT_SIZES_M["wheelbase"],
    (1 / 1.5, 2.0),
    ((0.5, "the wheelbase plus the track given (lx + ly is half of each)?"),),
)
"""Half the wheelbase plus half the track: within a wheelbase's sizes; an estimate half the
nominal is the whole wheelbase and track given."""


@dataclass(frozen=True)
class Mecanum:
    """A mecanum robot: four wheels with rollers at 45 deg (see the module docstring).

    Parameters
    ----------
    wheel_diameters_m : tuple of float
        ``(front_left, front_right, rear_left, rear_right)`` [m].
    lx_plus_ly_m : float
        Half the wheelbase plus half the track [m] (``kinematics.sum_of_robot_center_projection_on_X_Y_axis``).
    """

    wheel_diameters_m: tuple[float, float, float, float]
    lx_plus_ly_m: float

    kind: ClassVar[str] = "mecanum"
    joint_roles: ClassVar[tuple[str, ...]] = ROLES
    rolling: ClassVar[tuple[bool, ...]] = (True, True, True, True)
    parameter_names: ClassVar[tuple[str, ...]] = (
        "diameter_front_left_m",
        "diameter_front_right_m",
        "diameter_rear_left_m",
        "diameter_rear_right_m",
        "lx_plus_ly_m",
    )
    moves: ClassVar[tuple[str, ...]] = (
        "straight", "back", "left", "right", "diagonal", "arc+", "arc-", "spin+", "spin-",
    )  # fmt: skip

    # the signs of each wheel's travel in (v_x, v_y, omega k)
    _SIGNS: ClassVar[FloatArray] = np.array([[1.0, 1.0, 1.0, 1.0], [-1.0, 1.0, 1.0, -1.0], [-1.0, 1.0, -1.0, 1.0]])

    def __post_init__(self) -> None:
        d = tuple(self.wheel_diameters_m)
        if len(d) != 4:
            raise InputError(f"`wheel_diameters_m` needs four diameters (FL, FR, RL, RR), got {len(d)}")
        object.__setattr__(
            self, "wheel_diameters_m", tuple(positive_parameter(f"wheel_diameters_m[{i}]", v) for i, v in enumerate(d))
        )
        object.__setattr__(self, "lx_plus_ly_m", positive_parameter("lx_plus_ly_m", self.lx_plus_ly_m))

    @classmethod
    def uniform(cls, wheel_diameter_m: float, lx_plus_ly_m: float) -> Mecanum:
        """Four wheels of one diameter."""
        return cls((wheel_diameter_m, wheel_diameter_m, wheel_diameter_m, wheel_diameter_m), lx_plus_ly_m)

    @classmethod
    def from_vector(cls, p: ArrayLike) -> Mecanum:
        q = np.asarray(p, dtype=float)
        return cls((float(q[0]), float(q[1]), float(q[2]), float(q[3])), float(q[4]))

    def vector(self) -> FloatArray:
        return np.array([*self.wheel_diameters_m, self.lx_plus_ly_m])

    def with_vector(self, p: ArrayLike) -> Mecanum:
        return self.from_vector(p)

    def rolling_diameters_m(self) -> FloatArray:
        return np.asarray(self.wheel_diameters_m, dtype=float)

    def twist(self, values: ArrayLike, p: ArrayLike | None = None) -> FloatArray:
        q = self.vector() if p is None else np.asarray(p, dtype=float)
        u = 0.5 * q[:4] * np.asarray(values, dtype=float)
        t = u @ self._SIGNS.T * 0.25
        t[..., 2] = t[..., 2] / q[4]
        return np.asarray(t, dtype=float)

    def joint_motion(self, vx_mps: ArrayLike, vy_mps: ArrayLike, omega_radps: ArrayLike, dt_s: float) -> FloatArray:
        vx, vy, w = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (vx_mps, vy_mps, omega_radps)))
        tw = np.stack([vx, vy, w * self.lx_plus_ly_m], axis=-1)
        travel = tw @ self._SIGNS  # each wheel's rim speed
        return np.asarray(travel * dt_s / (0.5 * np.asarray(self.wheel_diameters_m)), dtype=float)


def wheel_factors(diameters_m: Sequence[float], ci95_m: Sequence[Interval | None]) -> tuple[tuple[float, ...], bool]:
    """Each wheel's diameter over the mean, and whether they differ beyond their 95 % intervals
    (some wheel's interval leaves out the mean)."""
    mean = sum(diameters_m) / len(diameters_m)
    factors = tuple(d / mean for d in diameters_m)
    apart = any(ci is not None and not ci[0] <= mean <= ci[1] for ci in ci95_m)
    return factors, apart and len(factors) > 1


def _wheels(g: Kinematics, ci95: Mapping[str, Interval | None]) -> tuple[tuple[float, ...], list[Interval | None]]:
    assert isinstance(g, Mecanum)
    return g.wheel_diameters_m, [ci95.get(f"diameter_{r}_m") for r in ROLES]


class _MecanumKind(Kind):
    name = Mecanum.kind
    noun = "mecanum robot"
    title = "Mecanum"
    geometry = Mecanum
    controller = "mecanum_drive_controller"
    drawable = True
    parameters = (
        *(Parameter(f"diameter_{r}_m", ("wheel_diameters_mm", r), "mm", f"wheel diameter {a}") for r, a in
          zip(ROLES, ("FL", "FR", "RL", "RR"))),
        Parameter("lx_plus_ly_m", ("lx_plus_ly_mm",), "mm", "lx + ly"),
    )  # fmt: skip
    sizes = (
        Size(
            "wheel_diameter_mm",
            tuple(f"diameter_{r}_m" for r in ROLES),
            QUANTITIES["diameter"],
            "wheel diameter",
            "D",
            alternative=Alternative("wheel_radius_m", 2.0, "R"),
        ),
        Size(
            "lx_plus_ly_mm",
            ("lx_plus_ly_m",),
            LX_PLUS_LY,
            "lx + ly",
            "S",
            "half the wheelbase plus half the track",
            "nominal half wheelbase plus half track (sum_of_robot_center_projection_on_X_Y_axis).",
        ),
    )
    joints = (
        JointOption(
            "joints",
            ROLES,
            "FL,FR,RL,RR",
            "front left, front right, rear left, rear right",
            "JointState names of the wheels.",
        ),
    )
    legend = (
        "wheel diameters: each wheel's effective rolling diameter; lx + ly: half the wheelbase plus half the "
        "track (mecanum_drive_controller's sum_of_robot_center_projection_on_X_Y_axis).",
    )
    sim_joints = tuple(f"{r}_wheel_joint" for r in ROLES)
    turn_backwards = (
        "the wheels' joints turn backwards when the robot drives forward, or the joints are in another order "
        "(FL,FR,RL,RR)"
    )
    turn_mirrored = "the wheels' joints given in another order (`joints` FL,FR,RL,RR)"
    role_words = {
        "front_left": (("front", "left"), ("fl",), ("lf",)),
        "front_right": (("front", "right"), ("fr",), ("rf",)),
        "rear_left": (("rear", "left"), ("rl",), ("lr",), ("bl",), ("lb",)),
        "rear_right": (("rear", "right"), ("rr",), ("br",), ("rb",)),
    }

    def advice(self, coverage: Coverage) -> list[str]:
        if coverage.sideways_m >= 0.05 * max(coverage.travel_m, 1e-9):
            return []
        return [
            "the robot never moves sideways: the wheel diameters' front-rear and diagonal differences cannot be "
            "told from the lidar's position and yaw, nor `lx + ly` from the radii with them; drive sideways "
            "both ways (and diagonally)"
        ]

    def negative(self, g: FloatArray, bad: list[str]) -> tuple[list[str], str]:
        if "lx_plus_ly_m" in bad:
            return super().negative(g, bad)
        wheels = ", ".join(n.removeprefix("diameter_").removesuffix("_m").replace("_", " ") for n in bad)
        return bad, (
            f"the {wheels} wheel's joint turns backwards when the robot drives forward, or the joints are in "
            "another order (FL,FR,RL,RR)"
        )

    def ros2_parameters(self, g: Kinematics) -> dict[str, Any]:
        """mecanum_drive_controller's ``kinematics.wheels_radius`` (the four wheels' mean) and
        ``kinematics.sum_of_robot_center_projection_on_X_Y_axis`` (doubles, metres)."""
        assert isinstance(g, Mecanum)
        mean = sum(g.wheel_diameters_m) / 4.0
        return {
            "kinematics": {
                "wheels_radius": float(0.5 * mean),
                "sum_of_robot_center_projection_on_X_Y_axis": float(g.lx_plus_ly_m),
            }
        }

    def ros2_joints(self, joints: Mapping[str, str]) -> dict[str, Any]:
        """mecanum_drive_controller's ``<wheel>_wheel_command_joint_name`` of each wheel (strings,
        required; its state joints are the command joints unless named otherwise)."""
        return {f"{r}_wheel_command_joint_name": str(joints[r]) for r in ROLES}

    def ros2_notes(
        self,
        g: Kinematics,
        ci95: Mapping[str, Interval | None],
        steering_in_use: tuple[float, float],
        joints: Mapping[str, str] | None = None,
    ) -> list[str]:
        diameters, cis = _wheels(g, ci95)
        factors, apart = wheel_factors(diameters, cis)
        if not apart:
            return [
                "the four wheel diameters agree within their 95 % intervals: wheels_radius is their mean "
                f"({', '.join(f'{d * 1e3:.3f}' for d in diameters)} mm)"
            ]
        lines = [
            "the four wheel diameters differ beyond their 95 % intervals "
            f"({', '.join(f'{r} {d * 1e3:.3f} mm' for r, d in zip(ROLES, diameters))});",
            "mecanum_drive_controller has one radius (their mean): make each wheel's joint read the mean wheel's",
            "travel by dividing the mechanical_reduction of its transmission by its factor (r_i / r_mean):",
        ]
        return lines + [f"  {r}: {f:.6f}" for r, f in zip(ROLES, factors)]

    def export_json(self, g: Kinematics, ci95: Mapping[str, Interval | None]) -> dict[str, Any]:
        diameters, cis = _wheels(g, ci95)
        factors, apart = wheel_factors(diameters, cis)
        return {
            "wheel_diameters_mm": {r: d * 1e3 for r, d in zip(ROLES, diameters)},
            "wheel_factors": dict(zip(ROLES, factors)),
            "wheels_differ": apart,
        }

    def draw(self, u: Uniform) -> tuple[Kinematics, Kinematics]:
        """Nominal wheels of 70-150 mm and ``lx + ly`` of 200-500 mm (whole millimetres); each true
        diameter off by up to +-2 %, ``lx + ly`` by +-5 %."""
        d, k = round(u(70, 150)) * 1e-3, round(u(200, 500)) * 1e-3
        nominal = Mecanum.uniform(d, k)
        dd = tuple(d * (1 + u(-0.02, 0.02)) for _ in range(4))
        true = Mecanum((dd[0], dd[1], dd[2], dd[3]), k * (1 + u(-0.05, 0.05)))
        return nominal, true


KIND = _MecanumKind()
"""The mecanum robot."""
