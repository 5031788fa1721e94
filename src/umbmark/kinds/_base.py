"""What a kind of robot is to umbmark: the description each kind's module fills in (:class:`Kind`).

A kind holds in one place everything the rest of the package asks of it:

* its **geometry** (:attr:`Kind.geometry`, a :class:`~umbmark.model.kinematics.Kinematics`): the
  forward kinematics as its ros2 controller computes them, their inverse, the moves the
  simulator draws for it;
* its **parameters** (:class:`Parameter`: the library's name, the JSON key, the table's label),
  the **nominal sizes** a command line gives (:class:`Size`: the option, the quantity whose unit
  slips the checks name, the plausible range), its **joints** (:class:`JointOption`: the options
  naming them, in the order the geometry wants; the words their names carry,
  :meth:`Kind.guess_joints`) and the parameters estimated only on request (:class:`FitOption`);
* the other **readings of the joints given** worth trying against the lidar's motion
  (:class:`Reading`, :meth:`Kind.readings`: other orders, a drive and a steering joint
  exchanged, a steering zero a quarter turn off) and what each means (:meth:`Kind.reading_cause`);
* the **self-calibration**'s judgement of its kind: how far the steering turned each way
  (:meth:`Kind.steering_travel`), what driving the data lack (:meth:`Kind.advice`), what a fitted
  size below zero means (:meth:`Kind.negative`), what joints turning the other way from the lidar
  mean (:attr:`Kind.turn_backwards`, :attr:`Kind.turn_mirrored`);
* its **exports**: the formats (:attr:`Kind.export_formats`), the controller and its parameters
  (:meth:`Kind.ros2_parameters`, the joints' :meth:`Kind.ros2_joints`), the notes of
  its parameter file (:meth:`Kind.ros2_notes`), the JSON (:meth:`Kind.export_json`);
* its **report**: the table of its estimates (:attr:`Parameter.label`) and the legend
  (:attr:`Kind.legend`);
* the random robots of the **studies** (:meth:`Kind.draw`).

Options are named as the library names parameters (``drive_joint``, ``lx_plus_ly_mm``): the
command line makes its flags of them. Messages name them in backticks.

Imports numpy, :mod:`umbmark.model` and the base modules.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from umbmark._check import positive
from umbmark.errors import InputError
from umbmark.model.geometry import Quantity
from umbmark.model.kinematics import Kinematics

__all__ = [
    "Kind",
    "Geometry",
    "Parameter",
    "Size",
    "Alternative",
    "JointOption",
    "FitOption",
    "Reading",
    "EditedFile",
    "Coverage",
    "positive_parameter",
    "finite_parameter",
    "check_fields",
]

FloatArray = NDArray[np.float64]
Interval = tuple[float, float]
CiOf = Callable[[str, float], "list[float] | None"]
Uniform = Callable[[float, float], float]

# a JSON value in its unit -> SI, and SI -> the JSON's unit (by the unit's name)
_FROM_UNIT: dict[str, Callable[[float], float]] = {"mm": lambda v: v * 1e-3, "deg": math.radians, "": float}
_TO_UNIT = {"mm": 1e3, "deg": math.degrees(1.0), "": 1.0}


def positive_parameter(name: str, v: Any) -> float:
    """A geometry's parameter that must be a positive number (a ``InputError`` naming it)."""
    if not (isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)):
        raise InputError(f"`{name}` must be a positive number, got {v!r}")
    return positive(f"`{name}`", v)


def finite_parameter(name: str, v: Any) -> float:
    """A geometry's parameter that must be a finite number (a ``InputError`` naming it)."""
    if not (isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and math.isfinite(v)):
        raise InputError(f"`{name}` must be a finite number, got {v!r}")
    return float(v)


class Geometry(Kinematics, Protocol):
    """A kind's geometry class: :class:`~umbmark.model.kinematics.Kinematics` made from its vector."""

    @classmethod
    def from_vector(cls, p: ArrayLike) -> Kinematics:
        """The geometry of the parameters ``p`` (SI, in ``parameter_names`` order)."""
        ...


@dataclass(frozen=True)
class Parameter:
    """One parameter of a kind's geometry.

    Attributes
    ----------
    name : str
        The geometry's name of it (SI: ``wheel_diameter_m``), in ``parameter_names`` order.
    key : tuple of str
        Where the JSON keeps it (``("wheel_diameters_mm", "front_left")``: nested); its 95 %
        interval sits under the first key with ``_ci95``.
    unit : str
        The JSON's unit: ``"mm"`` (of metres), ``"deg"`` (of radians) or ``""`` (as is).
    label : str
        How a table names it (without the unit).
    digits : int
        Decimals in a table.
    nominal : float, optional
        Its nominal value when no size of the command line gives it (a steering offset's 0).
    """

    name: str
    key: tuple[str, ...]
    unit: str
    label: str
    digits: int = 3
    nominal: float | None = None

    @property
    def factor(self) -> float:
        """SI to the JSON's unit."""
        return _TO_UNIT[self.unit]

    @property
    def ci_key(self) -> tuple[str, ...]:
        """Where the JSON keeps its 95 % interval."""
        return (f"{self.key[0]}_ci95", *self.key[1:])

    @property
    def path(self) -> str:
        """Its JSON key as one string, nested keys joined by ``.`` (``wheel_diameters_mm.front_left``)."""
        return ".".join(self.key)

    @property
    def table_label(self) -> str:
        """The label with its unit (``wheelbase [mm]``)."""
        return f"{self.label} [{self.unit}]" if self.unit else self.label

    def from_json(self, v: float) -> float:
        """A JSON value in SI."""
        return _FROM_UNIT[self.unit](v)


@dataclass(frozen=True)
class Alternative:
    """Another option that gives a size (in metres): ``--wheel-radius-m`` for the wheel diameter.

    Attributes
    ----------
    option : str
        Its name (``wheel_radius_m``).
    factor : float
        The size is the value times it (2 for a radius).
    metavar : str
        The placeholder of its value in messages.
    """

    option: str
    factor: float
    metavar: str


@dataclass(frozen=True)
class Size:
    """A nominal size the command line gives a kind of robot.

    Attributes
    ----------
    option : str
        Its option, in millimetres (``wheelbase_mm``).
    parameters : tuple of str
        The geometry's parameters it gives (all of a mecanum robot's four wheel diameters).
    quantity : Quantity
        What the checks of its value know of it (:class:`umbmark.model.geometry.Quantity`).
    label : str
        How messages name it (``wheelbase``).
    metavar : str
        The placeholder of its value in messages (``L``).
    describe : str
        What it measures, for a message that asks for it (may be empty).
    help : str
        The option's help (for the options of one kind only; a shared option has its command's).
    alternative : Alternative, optional
        Another option giving it in metres.
    fallback : str, optional
        Another size's option whose value it takes when it is not given (an Ackermann car's
        steering track width, the traction track width unless said otherwise); None: it must be given.
    """

    option: str
    parameters: tuple[str, ...]
    quantity: Quantity
    label: str
    metavar: str
    describe: str = ""
    help: str = ""
    alternative: Alternative | None = None
    fallback: str | None = None


@dataclass(frozen=True)
class JointOption:
    """An option that names some of a kind's joints.

    Attributes
    ----------
    option : str
        Its name (``drive_joint``, ``joints``).
    roles : tuple of str
        The roles of the joints it names, in order (one: one name; several: names separated by
        commas, in this order).
    metavar : str
        The placeholder of its value (``NAME``, ``FL,FR,RL,RR``).
    describe : str
        What it names, for a message that asks for it (may be empty).
    help : str
        The option's help.
    """

    option: str
    roles: tuple[str, ...]
    metavar: str
    describe: str = ""
    help: str = ""


@dataclass(frozen=True)
class FitOption:
    """A flag that asks to estimate a parameter the self-calibration leaves at its nominal value otherwise.

    Attributes
    ----------
    option : str
        Its name (``fit_steering_scale``).
    parameter : str
        The geometry's parameter it frees.
    help : str
        The option's help.
    check : bool
        When not asked for, the self-calibration estimates it anyway to see whether the data call
        for it, and warns when they do (a car's steering scale: a wrong one biases every estimate).
    """

    option: str
    parameter: str
    help: str
    check: bool = False


@dataclass(frozen=True)
class EditedFile:
    """A parameter file of the robot's own software that an export edits: the user's file with the
    values the calibration changes written in, every other line kept (F1TENTH's ``vesc.yaml``).

    Attributes
    ----------
    format : str
        The export format (one of the kind's :attr:`Kind.export_formats`).
    option : str
        The option naming the user's file (``vesc_config``).
    metavar : str
        The placeholder of its value (``VESC.yaml``).
    keys : tuple of str
        The values in use the file must hold (each a number): the calibration is applied to them.
    changed : tuple of str
        Of them, those the export writes anew (the rest kept).
    describe : str
        What the file is, for messages and the option's help.
    from_joints : str
        What the values written mean when the calibration read joint states rather than the
        odometry the file's values made (empty: the same).
    """

    format: str
    option: str
    metavar: str
    keys: tuple[str, ...]
    changed: tuple[str, ...]
    describe: str
    from_joints: str = ""


@dataclass(frozen=True)
class Reading:
    """Another way the joints given may have been meant (:meth:`Kind.readings`): which joint given
    plays each role, and a turn added to a joint's position.

    Attributes
    ----------
    order : tuple of int
        Per role (the geometry's ``joint_roles``), the index of the joint given that plays it.
    shift_rad : tuple of float
        Per role, what to add to its position [rad] (a steering joint's zero a quarter turn
        off); empty: nothing.
    words : str
        What the reading means, for a message (``the joints look like they are in another order``).
    """

    order: tuple[int, ...]
    shift_rad: tuple[float, ...] = ()
    words: str = "the joints look like they are in another order"

    def apply(self, positions: ArrayLike, rolling: Sequence[bool]) -> FloatArray:
        """The joints' positions ``(K, J)`` (given order) read so: reordered, a joint that rolls
        now but did not as given unwrapped (a steering angle the reader left as it was), shifted.

        Parameters
        ----------
        positions : array_like
            ``(K, J)`` the positions of the joints given, in the order given.
        rolling : sequence of bool
            Per role, whether its joint rolls (the geometry's ``rolling``).
        """
        pos = np.asarray(positions, dtype=float)
        out = pos[:, list(self.order)].copy()
        for j, (i, rolls) in enumerate(zip(self.order, rolling)):
            if rolls and not rolling[i]:
                out[:, j] = np.unwrap(out[:, j])
        if self.shift_rad:
            out += np.asarray(self.shift_rad, dtype=float)
        return np.asarray(out, dtype=float)


_WORD = re.compile(r"[A-Z]?[a-z]+|[A-Z]+(?![a-z])|\d+")


def name_words(name: str) -> frozenset[str]:
    """The words of a joint's name, lower case (``FrontLeftWheel_joint``: front, left, wheel, joint;
    ``back`` read as ``rear``)."""
    words = {w.lower() for w in _WORD.findall(name)}
    return frozenset("rear" if w == "back" else w for w in words)


class Coverage(Protocol):
    """How a robot drove over a self-calibration's intervals
    (:class:`umbmark.correct.selfcal.kinematic.DrivingCoverage`)."""

    @property
    def travel_m(self) -> float: ...

    @property
    def sideways_m(self) -> float: ...

    @property
    def steer_left_m(self) -> float: ...

    @property
    def steer_right_m(self) -> float: ...


def _put(out: dict[str, Any], key: tuple[str, ...], value: Any) -> None:
    d = out
    for k in key[:-1]:
        d = d.setdefault(k, {})
    d[key[-1]] = value


def _get(d: Mapping[str, Any], key: tuple[str, ...]) -> Any:
    v: Any = d
    for k in key:
        v = v.get(k) if isinstance(v, Mapping) else None
    return v


def _interval(v: Any) -> Interval | None:
    if isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) for x in v):
        return float(v[0]), float(v[1])
    return None


class Kind:
    """A kind of robot: the description its module fills in (see the module docstring).

    Attributes
    ----------
    name : str
        Its name (``--kinematics``'s choice, the JSON's ``kinematics``).
    noun : str
        How messages name it (``mecanum robot``).
    title : str
        How an option's help names it (``Mecanum``).
    geometry : type
        Its geometry class (:class:`Geometry`).
    parameters : tuple of Parameter
        Its geometry's parameters, in ``parameter_names`` order.
    sizes : tuple of Size
        The nominal sizes the command line gives it.
    joints : tuple of JointOption
        The options naming its joints; their roles in order are the geometry's ``joint_roles``.
    fits : tuple of FitOption
        The parameters estimated only on request.
    held : tuple of str
        The parameters never estimated: held at the nominal values the command line gives (an
        Ackermann car's track widths, which its odometry hardly depends on).
    reads_odometry : bool
        Its self-calibration also reads the robot's own odometry (``nav_msgs/Odometry``,
        ``odom_topic``) in place of joint states (:meth:`joints_from_odometry`).
    controller : str
        The ros2_controllers controller of its kind (the parameter file's default name).
    export_formats : tuple of str
        The formats its calibration exports in.
    edited_files : tuple of EditedFile
        The formats among them that edit a parameter file of the user's (:meth:`edited_values`).
    differential : bool
        Calibrated by the differential drive's own pipeline (UMBmark's correction factors, its
        history): the default kind.
    drawable : bool
        The studies draw random robots of it (:meth:`draw`).
    legend : tuple of str
        What its table's rows mean.
    sim_joints : tuple of str
        The joint names of its simulated bags, in the roles' order.
    turn_backwards, turn_mirrored : str
        The likely causes when the lidar turns the other way from the joints: with the robot
        also moving back where the joints drive forward, and without.
    role_words : mapping
        Per role, the words a joint's name carries when it plays it (alternatives, each a tuple
        of words all in the name: :func:`name_words`); a role missing: the words of its name
        (``front_left``: front and left).
    """

    name: ClassVar[str]
    noun: ClassVar[str]
    title: ClassVar[str]
    geometry: ClassVar[type[Geometry]]
    parameters: ClassVar[tuple[Parameter, ...]]
    sizes: ClassVar[tuple[Size, ...]]
    joints: ClassVar[tuple[JointOption, ...]]
    fits: ClassVar[tuple[FitOption, ...]] = ()
    held: ClassVar[tuple[str, ...]] = ()
    reads_odometry: ClassVar[bool] = False
    controller: ClassVar[str]
    export_formats: ClassVar[tuple[str, ...]] = ("ros2", "json", "urdf", "tf")
    edited_files: ClassVar[tuple[EditedFile, ...]] = ()
    differential: ClassVar[bool] = False
    drawable: ClassVar[bool] = False
    legend: ClassVar[tuple[str, ...]] = ()
    sim_joints: ClassVar[tuple[str, ...]] = ()
    turn_backwards: ClassVar[str] = "the joints turn backwards when the robot drives forward"
    turn_mirrored: ClassVar[str] = "the joints given in another order"
    role_words: ClassVar[Mapping[str, tuple[tuple[str, ...], ...]]] = {}

    def __repr__(self) -> str:
        return f"<kind {self.name}>"

    # ------------------------------------------------------------ parameters and options
    @property
    def steered(self) -> bool:
        """Whether it has a steering joint (whose transmission an export may compose with)."""
        return not all(self.geometry.rolling)

    @property
    def optional_parameters(self) -> tuple[str, ...]:
        """The parameters estimated only on request (:attr:`fits`)."""
        return tuple(f.parameter for f in self.fits)

    def default_fit(self) -> tuple[str, ...]:
        """The parameters a self-calibration estimates unless asked otherwise."""
        skip = set(self.optional_parameters) | set(self.held)
        return tuple(n for n in self.geometry.parameter_names if n not in skip)

    def fit_of(self, asked: Iterable[str]) -> tuple[str, ...] | None:
        """The parameters to estimate when the fit options ``asked`` (names of :attr:`fits`) are set:
        None (the default ones) when none is.

        Raises
        ------
        InputError
            An option that is not one of this kind's.
        """
        asked = tuple(asked)
        own = {f.option: f.parameter for f in self.fits}
        unknown = [a for a in asked if a not in own]
        if unknown:
            raise InputError(f"`{unknown[0]}` is not a {self.noun}'s")
        if not asked:
            return None
        freed = {own[a] for a in asked}
        default = self.default_fit()
        return tuple(n for n in self.geometry.parameter_names if n in default or n in freed)

    def option_names(self) -> tuple[str, ...]:
        """Every option of its own: joints, sizes (and their alternatives), fits."""
        out = [j.option for j in self.joints] + [f.option for f in self.fits]
        for s in self.sizes:
            out.append(s.option)
            if s.alternative is not None:
                out.append(s.alternative.option)
        return tuple(dict.fromkeys(out))

    def nominal(self, sizes_m: Mapping[str, float]) -> Kinematics:
        """The nominal geometry of its sizes.

        Parameters
        ----------
        sizes_m : mapping
            :attr:`Size.option` -> the size [m] (every size of the kind).

        Returns
        -------
        Kinematics
            The parameters no size gives at their :attr:`Parameter.nominal`.

        Raises
        ------
        InputError
            A size missing, or a geometry its class refuses.
        """
        given: dict[str, float] = {}
        for s in self.sizes:
            v = sizes_m.get(s.option)
            if v is None and s.fallback is not None:
                v = sizes_m.get(s.fallback)
            if v is None:
                raise InputError(f"the nominal {s.label} of the {self.noun} (`{s.option}`) is missing")
            for name in s.parameters:
                given[name] = float(v)
        values = []
        for p in self.parameters:
            v = given.get(p.name, p.nominal)
            if v is None:
                raise InputError(f"no nominal value of the {self.noun}'s `{p.name}`")
            values.append(v)
        return self.geometry.from_vector(values)

    # ------------------------------------------------------------ JSON
    def geometry_json(self, g: Kinematics, ci: CiOf | None = None) -> dict[str, Any]:
        """A geometry's JSON keys (:attr:`Parameter.key`, in mm and degrees), each followed by its
        95 % interval from ``ci(name, factor)`` when ``ci`` is given."""
        out: dict[str, Any] = {}
        for p, v in zip(self.parameters, g.vector()):
            _put(out, p.key, float(v) * p.factor)
            if ci is not None:
                _put(out, p.ci_key, ci(p.name, p.factor))
        return out

    def geometry_from_json(self, d: Mapping[str, Any], source: str) -> tuple[Kinematics, dict[str, Interval | None]]:
        """The geometry and its 95 % intervals (SI; None where not estimated) in a self-calibration's JSON.

        Raises
        ------
        InputError
            A value that is not a number, a group of keys that is not the kind's, a size that is
            not positive.
        """
        values, cis = [], {}
        for p in self.parameters:
            if len(p.key) > 1:
                group = d.get(p.key[0])
                want = [q.key[1] for q in self.parameters if q.key[0] == p.key[0]]
                if not isinstance(group, dict) or set(group) != set(want):
                    raise InputError(f"{p.key[0]!r} must hold {', '.join(want)}", source)
            v = _get(d, p.key)
            if v is None and p.name in self.optional_parameters and p.nominal is not None:
                values.append(p.nominal)
            elif isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise InputError(f"{p.key[-1]!r} must be a number: not a {self.noun}'s calibration", source)
            else:
                values.append(p.from_json(float(v)))
            c = _interval(_get(d, p.ci_key))
            cis[p.name] = None if c is None else (p.from_json(c[0]), p.from_json(c[1]))
        for p, v in zip(self.parameters, values):
            if p.name.endswith("_m") and not v > 0:
                raise InputError(f"a {p.label} that is not positive", source)
        try:
            return self.geometry.from_vector(values), cis
        except InputError as err:
            raise InputError(f"not a {self.noun}'s geometry: {err.message}", source) from None

    def estimates_json(self, d: Mapping[str, Any]) -> list[tuple[Parameter, float, Interval | None]]:
        """Each parameter's value and 95 % interval in a result's JSON, in the JSON's units (the
        interval None where it was not estimated); a parameter the JSON lacks is left out."""
        out = []
        for p in self.parameters:
            v = _get(d, p.key)
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
                out.append((p, float(v), _interval(_get(d, p.ci_key))))
        return out

    def describe_json(self, d: Mapping[str, Any], estimated: bool = True) -> str:
        """A result's geometry in words: ``wheel diameter 252.483 mm, wheelbase 789.966 mm, ...``
        (``estimated``: only the parameters estimated, those with an interval)."""
        return ", ".join(
            f"{p.label} {v:.{p.digits}f}{' ' + p.unit if p.unit else ''}"
            for p, v, ci in self.estimates_json(d)
            if ci is not None or not estimated
        )

    def truth(self, g: Kinematics) -> dict[str, float]:
        """The values a self-calibration estimates by default, under their JSON keys as one string
        (:attr:`Parameter.path`) in the JSON's units."""
        default = self.default_fit()
        return {p.path: float(v) * p.factor for p, v in zip(self.parameters, g.vector()) if p.name in default}

    # ------------------------------------------------------------ self-calibration
    def steering_travel(self, nominal: Kinematics, values: FloatArray) -> tuple[float, float]:
        """The distance the wheels rolled with the steering beyond 5 deg to the left and to the
        right [m] over joint steps ``values`` (``(0, 0)`` without steering)."""
        return 0.0, 0.0

    def advice(self, coverage: Coverage) -> list[str]:
        """What the driving lacks for this kind's parameters, each with what to drive (beyond the
        turns both ways every kind needs)."""
        return []

    def negative(self, g: FloatArray, bad: list[str]) -> tuple[list[str], str]:
        """A fit that needs the sizes ``bad`` (parameter names) negative: the sizes to name and why.

        Parameters
        ----------
        g : numpy.ndarray
            The fitted geometry's vector.
        bad : list of str
            Its lengths that are not positive.

        Returns
        -------
        tuple
            ``(names, why)``: no names when the fit is a geometry after all.
        """
        return bad, "the joints are in another order or turn backwards"

    # ------------------------------------------------------------ joints
    def joint_flags(self, names: Sequence[str] | None = None) -> str:
        """The options naming joints, as messages name options: ``names`` (one per role, in the
        roles' order) or, without them, the options' placeholders.

        ``joints=a,b,c,d (in this order: front_left, front_right, rear_left, rear_right)`` for an
        option of several roles, ``drive_joint=a steer_joint=b`` for options of one, each
        option in backticks (the command line prints its flag).
        """
        parts, i = [], 0
        for j in self.joints:
            n = len(j.roles)
            value = j.metavar if names is None else ",".join(names[i : i + n])
            i += n
            order = f" (in this order: {', '.join(j.roles)})" if n > 1 else ""
            parts.append(f"`{j.option}={value}`{order}")
        return " ".join(parts)

    def guess_joints(self, names: Sequence[str]) -> tuple[str, ...] | None:
        """The joints of a JointState topic that play the roles, by the words of their names
        (:attr:`role_words`): one per role, in the roles' order; None where the words do not
        tell (a role no name or several names fit)."""
        words = {n: name_words(n) for n in names}

        def fits(role: str, n: str) -> bool:
            alts = self.role_words.get(role) or (tuple(role.split("_")),)
            return any(set(a) <= words[n] for a in alts)

        roles = self.geometry.joint_roles
        found = {r: [n for n in names if fits(r, n)] for r in roles}
        shared = {n for r in roles for n in found[r] if sum(n in found[q] for q in roles) > 1}
        picked = [[n for n in found[r] if n not in shared] for r in roles]
        if any(len(p) != 1 for p in picked):
            return None
        return tuple(p[0] for p in picked)

    def readings(self) -> tuple[Reading, ...]:
        """The other readings of the joints given that a self-calibration tries against the lidar's
        motion (:mod:`umbmark.realrobot.kinematic`): by default every other order of them (up to
        five joints)."""
        n = len(self.geometry.joint_roles)
        if n > 5:
            return ()
        same = tuple(range(n))
        return tuple(Reading(p) for p in itertools.permutations(range(n)) if p != same)

    def reading_cause(self, reading: Reading, names: Sequence[str]) -> tuple[str, str]:
        """What a reading the lidar agrees with means, and what to do: ``(words, remedy)``, by
        default its words and the options naming the joints so (``names``: the joints given, in
        the order given)."""
        return reading.words, self.joint_flags([names[i] for i in reading.order])

    # ------------------------------------------------------------ the robot's own odometry
    def joints_from_odometry(self, nominal: Kinematics, pose: FloatArray) -> FloatArray:
        """The joints an odometry computed with the nominal geometry turned into these poses
        (:attr:`reads_odometry`): ``(K, J)`` positions in the roles' order at the poses' stamps,
        rolling joints cumulative from 0, a steering joint the angle it held over the step that
        ends at each stamp (the first stamp: the first step's).

        Parameters
        ----------
        nominal : Kinematics
            The geometry the odometry was computed with.
        pose : numpy.ndarray
            ``(K, 3)`` the odometry's poses ``(x_m, y_m, yaw_rad)`` in time order (yaw wrapped or not).

        Raises
        ------
        InputError
            A kind that reads no odometry (:meth:`odometry_refusal`).
        """
        raise InputError(self.odometry_refusal())

    def odometry_refusal(self) -> str:
        """Why its self-calibration reads no odometry (``odom_topic``), and what to give instead."""
        return f"a {self.noun} is read from its joint states (JointState), not from an odometry (`odom_topic`)"

    # ------------------------------------------------------------ exports
    def ros2_joints(self, joints: Mapping[str, str]) -> dict[str, Any]:
        """The controller's parameters naming its joints (``traction_joints_names``), from the joints the
        recording shows (role -> name, :attr:`JointOption.roles`); empty when it names none."""
        return {}

    def edited_values(
        self, fmt: str, g: Kinematics, nominal: Kinematics, in_use: Mapping[str, float]
    ) -> dict[str, float]:
        """The values a parameter file of the user's gets (:attr:`edited_files`): its
        :attr:`EditedFile.changed` keys calibrated from the values in use (every one of its
        :attr:`EditedFile.keys`, numbers), by the estimate ``g`` against the nominal geometry.

        Raises
        ------
        InputError
            A value in use that cannot be calibrated (a gain of 0), naming its key; a format it does
            not edit.
        """
        raise InputError(f"a {self.noun}'s calibration edits no {fmt} file")

    def edited_notes(self, fmt: str, g: Kinematics, ci95: Mapping[str, Interval | None]) -> list[str]:
        """What else the user's parameter file of ``fmt`` should change that the export does not write
        (a value in another node's block, an estimate the file's keys do not hold)."""
        return []

    def ros2_parameters(self, g: Kinematics) -> dict[str, Any]:
        """The controller's ``ros__parameters`` of a geometry (ros2_controllers' names and types)."""
        raise InputError(f"no ros2 controller's parameters of a {self.noun}")

    def ros2_notes(
        self,
        g: Kinematics,
        ci95: Mapping[str, Interval | None],
        steering_in_use: tuple[float, float],
        joints: Mapping[str, str] | None = None,
    ) -> list[str]:
        """The lines that follow the parameters in the file: what the controller has no parameter for.

        Parameters
        ----------
        g : Kinematics
        ci95 : mapping
            Parameter -> its 95 % interval (SI) or None.
        steering_in_use : tuple of float
            ``(offset_rad, mechanical_reduction)`` of a steering joint's transmission when the
            data were recorded.
        joints : mapping, optional
            The joints the recording shows (role -> name); None when the calibration read none
            (an odometry).
        """
        return []

    def export_json(self, g: Kinematics, ci95: Mapping[str, Interval | None]) -> dict[str, Any]:
        """The keys of its JSON export after the controller's parameters."""
        return {}

    # ------------------------------------------------------------ studies
    def draw(self, u: Uniform) -> tuple[Kinematics, Kinematics]:
        """A random robot: ``(nominal, true)`` geometries drawn with ``u(low, high)`` (uniform).

        Raises
        ------
        InputError
            A kind the studies do not draw (:attr:`drawable`).
        """
        raise InputError(f"the studies draw no random {self.noun}")


def check_fields(kind: Kind) -> list[str]:
    """What does not fit in a kind's description (for its tests): parameters and roles against its geometry."""
    bad = []
    g = kind.geometry
    if tuple(p.name for p in kind.parameters) != tuple(g.parameter_names):
        bad.append("the parameters are not the geometry's parameter_names, in order")
    roles = tuple(r for j in kind.joints for r in j.roles)
    if roles != tuple(g.joint_roles):
        bad.append(f"the joint options name {roles}, the geometry's roles are {g.joint_roles}")
    for s in kind.sizes:
        unknown = set(s.parameters) - set(g.parameter_names)
        if unknown:
            bad.append(f"the size {s.option} gives unknown parameters {sorted(unknown)}")
    for f in kind.fits:
        if f.parameter not in g.parameter_names:
            bad.append(f"the fit option {f.option} frees an unknown parameter {f.parameter}")
    given = {p for s in kind.sizes for p in s.parameters}
    for p in kind.parameters:
        if p.name not in given and p.nominal is None:
            bad.append(f"no size gives {p.name} and it has no nominal value")
    if kind.drawable and len(kind.sim_joints) != len(g.joint_roles):
        bad.append("a drawable kind needs a simulated joint name per role")
    for h in kind.held:
        if h not in g.parameter_names or h in kind.optional_parameters:
            bad.append(f"the held parameter {h} is not a parameter estimated by default")
    options = {s.option for s in kind.sizes}
    for s in kind.sizes:
        if s.fallback is not None and s.fallback not in options:
            bad.append(f"the size {s.option} falls back on {s.fallback}, not a size of the kind")
    for e in kind.edited_files:
        if e.format not in kind.export_formats or not set(e.changed) <= set(e.keys):
            bad.append(f"the edited file of {e.format} is not an export format, or changes keys it does not read")
    return bad
