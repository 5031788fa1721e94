"""The typed configurations of the commands with many options (:mod:`umbmark.cli.command_config`):
every option of the command is in its configuration and takes its default from it, the defaults
shared with the library are the library's, ``--write-config`` then ``--config`` gives the same
configuration, and the command line's choices are the library's registries."""

from __future__ import annotations

import inspect
import math
import re

import click
import pytest
import yaml

from umbmark.cli import app, main
from umbmark.cli.command_config import (
    COMMAND_CONFIGS,
    LOG,
    REPLAY,
    SELFCAL,
    ReplayConfig,
    SelfcalConfig,
)

OWN = ("config", "write_config")  # the configuration file's own options


def _command(name: str) -> click.Command:
    cmd = app.get_command(click.Context(app), name)
    assert cmd is not None
    return cmd


def _options(cmd: click.Command) -> dict[str, click.Option]:
    return {p.name: p for p in cmd.params if isinstance(p, click.Option) and p.name and p.name not in OWN}


def _parse(name: str, args: list[str]) -> click.Context:
    """The command's parse of ``args`` (its configuration read, nothing run)."""
    return _command(name).make_context(name, args, parent=click.Context(app, info_name="umbmark"))


@pytest.mark.parametrize("name", sorted(COMMAND_CONFIGS))
def test_every_option_is_in_the_configuration_once(name):
    config = COMMAND_CONFIGS[name]
    leaves = [param for param, _, _ in config._leaves()]
    assert len(leaves) == len(set(leaves))  # one field per option: the flat names map back
    assert set(leaves) == set(_options(_command(name)))


@pytest.mark.parametrize("name", sorted(COMMAND_CONFIGS))
def test_each_flags_default_is_the_configurations(name):
    """What the command receives for an option not given is its configuration's default, and so is
    the default its option declares (and shows)."""
    config = COMMAND_CONFIGS[name]
    ctx = _parse(name, ["rec.bag"])
    defaults = config.defaults()
    for param, option in _options(_command(name)).items():
        assert ctx.params[param] == defaults[param], param
        if option.show_default:
            assert option.default == defaults[param], param
    assert config.from_params(ctx.params) == config()
    assert config().changed() == {}


def test_the_defaults_shared_with_the_library_are_the_librarys():
    from umbmark.cli.bags import interval_options
    from umbmark.cli.options import read_options, wheel_source
    from umbmark.correct.lsq import fit_lsq
    from umbmark.io.load import LOG_FORMATS, LogOptions
    from umbmark.io.wheels import TICK_MODES, WheelSource
    from umbmark.realrobot.kinematic_settings import KinematicSettings
    from umbmark.realrobot.selfcal import DEFAULT_KEYFRAMES, IntervalOptions
    from umbmark.realrobot.selfcal_settings import SelfcalSettings

    assert interval_options(SELFCAL.keyframes, SELFCAL.scans, SELFCAL.fit.min_intervals) == IntervalOptions()
    k = SELFCAL.keyframes
    assert (k.keyframe_mm * 1e-3, math.radians(k.keyframe_deg), k.keyframe_min_s, k.keyframe_s) == (
        DEFAULT_KEYFRAMES.min_distance_m,
        DEFAULT_KEYFRAMES.min_rotation_rad,
        DEFAULT_KEYFRAMES.min_interval_s,
        DEFAULT_KEYFRAMES.max_interval_s,
    )
    assert wheel_source(SELFCAL.wheels.params()) == WheelSource()
    assert read_options(LOG.params()) == LogOptions()
    assert (LOG.log_format, LOG.wheels.ticks) == (LOG_FORMATS[0], TICK_MODES[0])
    settings = SelfcalSettings(0.1, 0.3)
    assert (SELFCAL.scans.scan_topic, not SELFCAL.fit.keep_outliers, SELFCAL.fit.wheel_jitter) == (
        settings.scan_topic,
        settings.reject_outliers,
        settings.time_jitter,
    )
    kinematic = {f.name: f.default for f in KinematicSettings.__dataclass_fields__.values()}
    assert (kinematic["joint_topic"], kinematic["scan_topic"]) == (SELFCAL.wheels.joint_topic, SELFCAL.scans.scan_topic)
    lsq = {n: p.default for n, p in inspect.signature(fit_lsq).parameters.items()}
    assert (lsq["mode"], lsq["scale"], lsq["heading_weight_m"], lsq["points_per_run"]) == (
        REPLAY.lsq.lsq_mode,
        REPLAY.lsq.scale,
        REPLAY.lsq.heading_weight_m,
        REPLAY.lsq.points_per_run,
    )


SELFCAL_ARGS = [
    "--odom-topic", "/odom", "--wheel-diameter-mm", "200", "--wheelbase-mm", "400", "--keyframe-mm", "300",
    "--keyframe-deg", "5", "--scan-delay", "off", "--sensor-pose", "35,0,0", "--no-wheel-jitter", "--keep-outliers",
    "--min-intervals", "20", "--coarse", "--skip-check", "stamp_order", "--skip-check", "wheel_units",
    "--robot", "r1", "--record", "--recorded-at", "2026-05-01T14:30", "--window", "10min",
]  # fmt: skip


def test_selfcal_write_config_then_config_round_trips(tmp_path, capsys):
    """The options written by --write-config, read by --config, are the options given: the same
    configuration, and written again the same options."""
    bag = tmp_path / "drive.bag"
    bag.write_bytes(b"")
    first, second = tmp_path / "robot.yaml", tmp_path / "again.yaml"
    assert main(["selfcal", str(bag), *SELFCAL_ARGS, "--write-config", str(first)]) == 0
    assert main(["selfcal", str(bag), "--config", str(first), "--write-config", str(second)]) == 0
    assert capsys.readouterr().err.count("(16 given)") == 2
    assert yaml.safe_load(second.read_text()) == yaml.safe_load(first.read_text())  # in the options' order
    by_flags = SelfcalConfig.from_params(_parse("selfcal", [*SELFCAL_ARGS, str(bag)]).params)
    by_file = SelfcalConfig.from_params(_parse("selfcal", ["--config", str(first), str(bag)]).params)
    assert by_file == by_flags != SelfcalConfig()
    assert by_file.keyframes.keyframe_mm == 300.0 and by_file.fit.skip_check == ("stamp_order", "wheel_units")
    assert by_file.changed().keys() == {
        "odom_topic", "wheel_diameter_mm", "wheelbase_mm", "keyframe_mm", "keyframe_deg", "scan_delay", "sensor_pose",
        "wheel_jitter", "keep_outliers", "min_intervals", "coarse", "skip_check", "robot", "record", "recorded_at",
        "window",
    }  # fmt: skip


def test_the_next_command_names_the_bag_options_not_at_their_defaults():
    from umbmark.cli.selfcal import _bag_flags, _fit_flags

    cfg = SelfcalConfig.from_params(
        {
            "scan_topic": "/laser scan",
            "joints": "l,r",
            "ticks": "incremental",
            "pulses_per_wheel_rev": 4096.0,
            "scan_delay": " AUTO",
            "keyframe_mm": 250.0,
            "keyframe_s": 0.0,
            "coarse": True,
            "min_intervals": 12,
            "wheel_jitter": False,
        }
    )
    assert _bag_flags(cfg) == [
        "--scan-topic '/laser scan'",
        "--joints l,r",
        "--pulses-per-wheel-rev 4096.0",
        "--ticks incremental",
        "--keyframe-mm 250",
        "--keyframe-s 0",
        "--coarse",
    ]
    assert _fit_flags(cfg, bags=False) == ["--min-intervals 12", "--no-wheel-jitter"]
    assert _bag_flags(SelfcalConfig()) == []


def test_a_replays_configuration_holds_its_groups():
    cfg = ReplayConfig.from_params(_parse("replay", ["--method", "lsq", "--pool", "--lsq-mode", "end", "a"]).params)
    assert (cfg.method, cfg.lsq.pool, cfg.lsq.lsq_mode) == ("lsq", True, "end")
    assert cfg.changed() == {"method": "lsq", "pool": True, "lsq_mode": "end"}
    assert cfg.log == LOG


def test_the_choices_are_the_registries():
    """The log formats, the tick modes and the least squares' options the command line offers are
    the library's; every export format of every kind is named in ``export --format``'s help."""
    from umbmark.cli.kinematic import export_formats
    from umbmark.io.load import LOG_FORMATS
    from umbmark.io.wheels import TICK_MODES
    from umbmark.model.defaults import LSQ_MODES, LSQ_SCALES

    replay, selfcal, convert = (_options(_command(n)) for n in ("replay", "selfcal", "convert"))
    for options in (replay, convert):
        assert tuple(options["log_format"].type.choices) == LOG_FORMATS
    for options in (replay, selfcal, convert):
        assert tuple(options["ticks"].type.choices) == TICK_MODES
    assert tuple(replay["lsq_mode"].type.choices) == LSQ_MODES
    assert tuple(replay["scale"].type.choices) == LSQ_SCALES
    fmt = _options(_command("export"))["out_format"]
    assert tuple(fmt.type.choices) == export_formats()
    for name in export_formats():
        assert re.search(rf"\b{name}\b", fmt.help or ""), name
