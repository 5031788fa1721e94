"""The kinds of robot (umbmark.kinds): one module each, a registry the rest of the package asks
(a kind it has never heard of simulates, calibrates and exports), and the command line's choices
made from it."""

from __future__ import annotations

import math
import pkgutil
from dataclasses import dataclass
from typing import ClassVar

import click
import numpy as np
import pytest

import umbmark.kinds as kinds
from umbmark.errors import InputError
from umbmark.kinds import (
    DEFAULT_KIND,
    KINDS,
    Ackermann,
    Bicycle,
    DiffDrive,
    JointOption,
    Kind,
    Mecanum,
    Parameter,
    Size,
    Tricycle,
    kind_named,
    kind_of,
    kinds_with,
    quantity_named,
)
from umbmark.kinds._base import check_fields
from umbmark.kinds.mecanum import LX_PLUS_LY
from umbmark.model.geometry import QUANTITIES, nominal_slip, unit_slip
from umbmark.model.kinematic_drive import MOVES, KinematicRobot, kinematic_program, simulate_kinematic_drive
from umbmark.model.kinematics import JointIntervals, JointSteps, joint_intervals_from_motion
from umbmark.model.sensors import Lidar, SensorPose

EXAMPLES = {
    "diff_drive": DiffDrive(0.151, 0.149, 0.35),
    "tricycle": Tricycle(0.2525, 0.79, math.radians(1.5), 1.02),
    "mecanum": Mecanum((0.101, 0.0995, 0.1003, 0.0998), 0.405),
    "bicycle": Bicycle(0.1115, 0.33, math.radians(1.2), 1.04),
    "ackermann": Ackermann(0.2025, 0.6, 0.45, 0.42, math.radians(1.0), 1.03),
}


def test_every_module_of_the_package_is_a_registered_kind():
    modules = {m.name for m in pkgutil.iter_modules(kinds.__path__) if not m.name.startswith("_")}
    assert modules == {k.geometry.__module__.rsplit(".", 1)[1] for k in KINDS.values()}
    assert set(EXAMPLES) == set(KINDS)
    assert KINDS[DEFAULT_KIND].differential and sum(k.differential for k in KINDS.values()) == 1


@pytest.mark.parametrize("name", list(KINDS))
def test_a_kinds_description_fits_its_geometry(name):
    k = KINDS[name]
    assert check_fields(k) == []
    assert k.name == name == k.geometry.kind and kind_of(EXAMPLES[name]) is k
    assert set(k.geometry.moves) <= set(MOVES) and k.geometry.moves
    assert k.export_formats and k.controller.endswith("_controller")
    for option in k.option_names():
        assert k in kinds_with(option) and "-" not in option  # the library's names; the CLI makes the flags


def test_an_unknown_kind_is_one_line_naming_the_kinds():
    with pytest.raises(
        InputError,
        match="unknown kinematics 'unicycle' \\(choose from diff_drive, tricycle, mecanum, bicycle, ackermann\\)",
    ):
        kind_named("unicycle")
    with pytest.raises(InputError, match="unknown kinematics"):
        kind_of(object())  # type: ignore[arg-type]


def _intervals_of(g):
    """Each parameter's 95 % interval (SI) 1 % about it, and the ``ci(name, factor)`` of the JSON."""
    cis = {n: (0.99 * v, 1.01 * v) for n, v in zip(g.parameter_names, g.vector())}
    return cis, lambda n, f: [cis[n][0] * f, cis[n][1] * f]


@pytest.mark.parametrize("name", list(KINDS))
def test_the_json_of_a_geometry_reads_back(name):
    k, g = KINDS[name], EXAMPLES[name]
    cis, ci = _intervals_of(g)
    back, got = k.geometry_from_json(k.geometry_json(g, ci), "cal.json")
    assert type(back) is type(g)
    np.testing.assert_allclose(back.vector(), g.vector(), rtol=1e-12)
    for n, (lo, hi) in cis.items():
        assert got[n] == pytest.approx((lo, hi), rel=1e-12)
    assert k.truth(g) == {
        p.path: pytest.approx(v * p.factor) for p, v in zip(k.parameters, g.vector()) if p.name in k.default_fit()
    }


def test_the_geometrys_json_keys_are_the_pinned_ones():
    tri = KINDS["tricycle"].geometry_json(EXAMPLES["tricycle"], _intervals_of(EXAMPLES["tricycle"])[1])
    assert list(tri) == [
        "wheel_diameter_mm", "wheel_diameter_mm_ci95", "wheelbase_mm", "wheelbase_mm_ci95", "steering_offset_deg",
        "steering_offset_deg_ci95", "steering_scale", "steering_scale_ci95",
    ]  # fmt: skip
    assert tri["steering_offset_deg"] == pytest.approx(1.5) and tri["wheelbase_mm"] == pytest.approx(790.0)
    mec = KINDS["mecanum"].geometry_json(EXAMPLES["mecanum"])
    assert list(mec) == ["wheel_diameters_mm", "lx_plus_ly_mm"]
    assert list(mec["wheel_diameters_mm"]) == ["front_left", "front_right", "rear_left", "rear_right"]
    assert mec["wheel_diameters_mm"]["front_right"] == pytest.approx(99.5)
    dd = KINDS["diff_drive"].geometry_json(EXAMPLES["diff_drive"])
    assert list(dd) == ["wheel_diameter_left_mm", "wheel_diameter_right_mm", "wheelbase_mm"]


def test_a_json_of_another_kind_or_with_bad_values_is_refused():
    mec = KINDS["mecanum"].geometry_json(EXAMPLES["mecanum"])
    with pytest.raises(InputError, match="'wheel_diameter_mm' must be a number: not a tricycle's calibration"):
        KINDS["tricycle"].geometry_from_json(mec, "cal.json")
    three = {**mec, "wheel_diameters_mm": {r: 100.0 for r in ("front_left", "front_right", "rear_left")}}
    with pytest.raises(InputError, match="must hold front_left, front_right, rear_left, rear_right"):
        KINDS["mecanum"].geometry_from_json(three, "cal.json")
    tri = KINDS["tricycle"].geometry_json(EXAMPLES["tricycle"])
    with pytest.raises(InputError, match="wheelbase that is not positive"):
        KINDS["tricycle"].geometry_from_json({**tri, "wheelbase_mm": -790.0}, "cal.json")
    with pytest.raises(InputError, match="not a tricycle's geometry.*quarter turn"):
        KINDS["tricycle"].geometry_from_json({**tri, "steering_offset_deg": 120.0}, "cal.json")
    # the scale estimated only on request: absent, it is the nominal 1
    no_scale = {k: v for k, v in tri.items() if not k.startswith("steering_scale")}
    assert KINDS["tricycle"].geometry_from_json(no_scale, "cal.json")[0].steering_scale == 1.0


@pytest.mark.parametrize("name", list(KINDS))
def test_the_nominal_geometry_is_made_of_the_sizes(name):
    k = KINDS[name]
    sizes = {s.option: 0.1 * (i + 1) for i, s in enumerate(k.sizes)}
    g = k.nominal(sizes)
    values = dict(zip(g.parameter_names, g.vector()))
    for s in k.sizes:
        assert all(values[p] == sizes[s.option] for p in s.parameters)
    for p in k.parameters:
        if not any(p.name in s.parameters for s in k.sizes):
            assert values[p.name] == p.nominal
    with pytest.raises(InputError, match="missing"):
        k.nominal({})


def test_the_parameters_estimated_on_request():
    t = KINDS["tricycle"]
    assert t.optional_parameters == ("steering_scale",) and "steering_scale" not in t.default_fit()
    assert t.fit_of([]) is None and t.fit_of(["fit_steering_scale"]) == Tricycle.parameter_names
    with pytest.raises(InputError, match="not a mecanum robot's"):
        KINDS["mecanum"].fit_of(["fit_steering_scale"])


def test_a_kinds_own_size_names_its_unit_slips():
    assert quantity_named("lx_plus_ly") is LX_PLUS_LY and quantity_named("wheelbase") is QUANTITIES["wheelbase"]
    text = unit_slip(LX_PLUS_LY, 0.0004, "mm")
    assert text is not None and "mecanum robot's lx + ly" in text and "given in metres" in text
    assert unit_slip(LX_PLUS_LY, 0.4, "mm") is None
    assert nominal_slip(LX_PLUS_LY, 0.5) == "the wheelbase plus the track given (lx + ly is half of each)?"
    assert nominal_slip(LX_PLUS_LY, 1.9) is None
    with pytest.raises(InputError, match="unknown size"):
        quantity_named("track")


# ---------------------------------------------------------------- the command line's choices
def _options(command: str) -> dict[str, click.Option]:
    from umbmark.cli import app

    return {p.name: p for p in app.commands[command].params if isinstance(p, click.Option) and p.name}


@pytest.mark.parametrize("command", ["selfcal", "replay"])
def test_the_command_lines_kinds_are_the_registrys(command):
    opts = _options(command)
    kin = opts["kinematics"]
    assert isinstance(kin.type, click.Choice)
    assert list(kin.type.choices) == list(KINDS) and kin.default == DEFAULT_KIND
    for k in KINDS.values():
        assert set(k.option_names()) <= set(opts), k.name
        assert k.noun in (kin.help or "")


def test_the_export_formats_are_every_kinds():
    from umbmark.io.export import FORMATS

    fmt = _options("export")["out_format"]
    assert isinstance(fmt, click.Choice) or isinstance(fmt.type, click.Choice)
    assert tuple(fmt.type.choices) == tuple(dict.fromkeys(f for k in KINDS.values() for f in k.export_formats))
    assert KINDS[DEFAULT_KIND].export_formats == FORMATS  # the differential drive's export (umbmark.io.export)


def test_every_kinds_option_is_named_by_its_flag_in_messages():
    from umbmark.cli.app import PARAM_FLAGS, cli_message

    for k in KINDS.values():
        for n in k.option_names():
            assert PARAM_FLAGS[n] == "--" + n.replace("_", "-")
    assert cli_message("give `lx_plus_ly_mm`") == "give --lx-plus-ly-mm"


# ---------------------------------------------------------------- a kind the package has never heard of
@dataclass(frozen=True)
class EqualWheels:
    """A differential drive whose two wheels are one size: a kind for this test only."""

    wheel_diameter_m: float
    wheelbase_m: float

    kind: ClassVar[str] = "equal_wheels"
    joint_roles: ClassVar[tuple[str, ...]] = ("left", "right")
    rolling: ClassVar[tuple[bool, ...]] = (True, True)
    parameter_names: ClassVar[tuple[str, ...]] = ("wheel_diameter_m", "wheelbase_m")
    moves: ClassVar[tuple[str, ...]] = ("straight", "back", "arc+", "arc-", "spin+", "spin-")

    @classmethod
    def from_vector(cls, p):
        return cls(float(p[0]), float(p[1]))

    def _dd(self, p=None):
        q = self.vector() if p is None else np.asarray(p, dtype=float)
        return DiffDrive(q[0], q[0], q[1])

    def vector(self):
        return np.array([self.wheel_diameter_m, self.wheelbase_m])

    def with_vector(self, p):
        return self.from_vector(p)

    def rolling_diameters_m(self):
        return np.array([self.wheel_diameter_m, self.wheel_diameter_m])

    def twist(self, values, p=None):
        return self._dd(p).twist(values)

    def joint_motion(self, vx_mps, vy_mps, omega_radps, dt_s):
        return self._dd().joint_motion(vx_mps, vy_mps, omega_radps, dt_s)


class _EqualWheelsKind(Kind):
    name = EqualWheels.kind
    noun = "robot of equal wheels"
    title = "Equal wheels"
    geometry = EqualWheels
    controller = "diff_drive_controller"
    parameters = (
        Parameter("wheel_diameter_m", ("wheel_diameter_mm",), "mm", "wheel diameter"),
        Parameter("wheelbase_m", ("wheelbase_mm",), "mm", "wheelbase"),
    )
    sizes = (
        Size("wheel_diameter_mm", ("wheel_diameter_m",), QUANTITIES["diameter"], "wheel diameter", "D"),
        Size("wheelbase_mm", ("wheelbase_m",), QUANTITIES["wheelbase"], "wheelbase", "L"),
    )
    joints = (JointOption("joints", ("left", "right"), "LEFT,RIGHT"),)

    def ros2_parameters(self, g):
        return {"wheel_radius": 0.5 * g.wheel_diameter_m, "wheel_separation": g.wheelbase_m}


def test_a_kind_the_package_never_heard_of_drives_calibrates_and_exports(monkeypatch):
    """One module's worth of description is all the library needs: the simulator drives it, the
    self-calibration estimates it and judges it, its JSON and its ros2 export follow its description."""
    import yaml

    from umbmark.correct.selfcal.kinematic import kinematic_selfcal
    from umbmark.io.export_kinematic import format_kinematic_export, kinematic_calibration_from_dict

    toy = _EqualWheelsKind()
    monkeypatch.setitem(kinds._REGISTRY, toy.name, toy)
    assert check_fields(toy) == [] and KINDS[toy.name] is toy
    nominal, true = toy.nominal({"wheel_diameter_mm": 0.15, "wheelbase_mm": 0.34}), EqualWheels(0.152, 0.345)
    pose = SensorPose(0.2, -0.03, math.radians(2.0))
    robot = KinematicRobot(nominal, true, pose, Lidar(n_beams=30, range_noise_m=0.0, dropout_prob=0.0))
    moves, start = kinematic_program(robot, 60, seed=3)
    assert all(m.vy_mps == 0 for m in moves) and any(m.omega_radps < 0 for m in moves)
    log = simulate_kinematic_drive(moves, robot, start_pose=start)
    t = log.scan_t_s[::5]
    grid = np.unique(np.concatenate([log.t_s, t]))
    js, b = log.joint_steps(grid), np.searchsorted(grid, t)
    steps = JointSteps(js.values[b[0] : b[-1]], b - b[0], js.dt_s[b[0] : b[-1]])
    iv = joint_intervals_from_motion(steps, true, pose.as_array())
    noise = np.random.default_rng(1).normal(0.0, 1.0, iv.sensor.shape) * [0.001, 0.001, 0.002]
    r = kinematic_selfcal(JointIntervals(iv.dt_s, iv.steps, iv.sensor + noise), nominal)
    np.testing.assert_allclose(r.kinematics.vector(), true.vector(), rtol=5e-3)
    for n, v in zip(toy.geometry.parameter_names, true.vector()):
        lo, hi = r.ci95[n]
        assert lo - 0.5 * (hi - lo) <= v <= hi + 0.5 * (hi - lo), n
    d = r.to_dict()
    assert d["kinematics"] == toy.name and d["nominal"] == {"wheel_diameter_mm": 150.0, "wheelbase_mm": 340.0}
    assert d["wheel_diameter_mm"] == pytest.approx(152.0, rel=5e-3) and len(d["wheelbase_mm_ci95"]) == 2
    cal = kinematic_calibration_from_dict(d, "toy.json")
    text = format_kinematic_export(cal, "ros2")
    assert text.startswith("# umbmark self-calibration of a robot of equal wheels from toy.json")
    params = yaml.safe_load(text)["diff_drive_controller"]["ros__parameters"]
    est = r.kinematics
    want = {"wheel_radius": 0.5 * est.wheel_diameter_m, "wheel_separation": est.wheelbase_m}
    assert params == {k: pytest.approx(v, rel=1e-12) for k, v in want.items()}
    with pytest.raises(
        InputError, match="no standard ROS 1 controller .* export it as ros2 \\(diff_drive_controller\\), json"
    ):
        format_kinematic_export(cal, "ros1")
