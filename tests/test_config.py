"""``--config FILE`` and ``--write-config FILE`` of the commands with many options (``replay``,
``selfcal``, ``validate``): the file gives the options' defaults, the command line wins, the
values go through the flags' checks, and a bad file is one line naming the file and the line."""

from __future__ import annotations

import json
from pathlib import Path

import click
import pytest
from conftest import REPO
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.cli import app, main
from umbmark.cli.config import config_text, read_config

OPTIODOM = str(REPO / "data" / "optiodom" / "square" / "230620202144")


def _command(name: str) -> click.Command:
    cmd = app.get_command(click.Context(app), name)
    assert cmd is not None
    return cmd


def _json(capsys, args) -> dict:
    assert main(args) == 0
    return json.loads(capsys.readouterr().out)


def _error(capsys, args) -> str:
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    return err


def test_a_config_file_gives_what_the_flags_give(tmp_path, capsys):
    flags = ["--method", "exact", "--time-offset", "0", "--no-heldout"]
    by_flags = _json(capsys, ["replay", OPTIODOM, *flags, "--json"])
    cfg = tmp_path / "replay.yaml"
    assert main(["replay", OPTIODOM, *flags, "--write-config", str(cfg)]) == 0
    assert "wrote the options of umbmark replay" in capsys.readouterr().err
    text = cfg.read_text()
    assert "replay:" in text and "method: exact" in text and "no-heldout: true" in text
    by_file = _json(capsys, ["replay", OPTIODOM, "--config", str(cfg), "--json"])
    assert by_file == by_flags


def test_the_command_line_wins_and_other_sections_are_left_alone(tmp_path, capsys):
    cfg = tmp_path / "robot.yaml"
    cfg.write_text("selfcal:\n  keyframe-mm: 300\nreplay:\n  method: exact\n  no_heldout: yes\n")
    d = _json(capsys, ["replay", OPTIODOM, "--config", str(cfg), "--method", "bf", "--json"])
    assert d["method"] == "bf"
    d = _json(capsys, ["replay", OPTIODOM, "--config", str(cfg), "--json"])
    assert d["method"] == "exact" and d.get("heldout") is None


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("replay:\n  frobnicate: 3\n", "line 2: no option --frobnicate of umbmark replay"),
        ("replay:\n  heading-weight-m: 1_0\n", "line 2: --heading-weight-m: '1_0' is not a number"),
        ("replay:\n  no-heldout: maybe\n", "line 2: --no-heldout is a flag: true or false"),
        ("replay:\n  method: [bf, exact]\n", "line 2: --method takes one value"),
        ("replay:\n- method\n", "the options of replay are a mapping"),
        ("- replay\n", "a configuration is a mapping of commands"),
        ("replay: {method: bf\n", "not YAML"),
        ("replay:\n  method: nonsense\n", "'nonsense' is not one of"),
        ("replay:\n  wheel-diameter-mm: 0.084\n", "0.084 mm is no wheel's diameter"),
        (
            "replay:\n  method: exact\nselfcal:\n  keyframe-mm: 300\nreplay:\n  method: bf\n",
            "line 5: two replay: sections (lines 1 and 5): give each command's options in one",
        ),
        (
            "selfcall:\n  keyframe-mm: 300\n",
            "line 1: no command 'selfcall' (selfcal?): the sections are replay, selfcal",
        ),
        ("replay:\n  method: exact\n  method: bf\n", "line 3: --method given twice (lines 2 and 3)"),
        ("replay:\n  no-heldout: true\n  no_heldout: false\n", "line 3: --no-heldout given twice (lines 2 and 3)"),
    ],
)
def test_a_bad_config_is_one_line_naming_the_file(tmp_path, capsys, text, message):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(text)
    err = _error(capsys, ["replay", OPTIODOM, "--config", str(cfg), "--json"])
    assert message in err
    if "line" in message or "mapping" in message or "YAML" in message:
        assert str(cfg) in err


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="needs /dev/zero")
def test_an_endless_config_is_read_no_further_than_a_configuration_goes(tmp_path, capsys):
    """--config /dev/zero (or a file of megabytes): refused after a megabyte, not read until the
    memory is gone."""
    err = _error(capsys, ["replay", OPTIODOM, "--config", "/dev/zero"])
    assert "/dev/zero: longer than 1,048,576 bytes (a device or a pipe, not a file)" in err
    big = tmp_path / "big.yaml"
    big.write_text("replay:\n" + "# padding\n" * 120_000)
    assert "big.yaml: longer than 1,048,576 bytes: not the file expected here" in _error(
        capsys, ["replay", OPTIODOM, "--config", str(big)]
    )


def test_a_missing_config_and_a_config_replaced_by_its_own_output(tmp_path, capsys):
    err = _error(capsys, ["replay", OPTIODOM, "--config", str(tmp_path / "none.yaml")])
    assert "none.yaml" in err and "not found" in err
    cfg = tmp_path / "c.yaml"
    cfg.write_text("replay:\n  method: bf\n")
    before = cfg.read_text()
    err = _error(capsys, ["replay", OPTIODOM, "--config", str(cfg), "--write-config", str(cfg)])
    assert "--write-config" in err and "--config" in err
    assert cfg.read_text() == before


@pytest.mark.parametrize("name", ["replay", "selfcal", "validate"])
def test_every_option_of_the_wide_commands_can_be_configured(name):
    cmd = _command(name)
    names = [p.name for p in cmd.params if isinstance(p, click.Option) and p.name not in ("config", "write_config")]
    assert len(names) >= 20
    text = "\n".join(f"  {n.replace('_', '-')}: {'true' if _is_flag(cmd, n) else 'x'}" for n in names)
    got = read_config_text(f"{name}:\n{text}\n", cmd, name)
    assert sorted(got) == sorted(names)


def _is_flag(cmd, name):
    return next(p for p in cmd.params if p.name == name).is_flag


def read_config_text(text, cmd, section):
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "c.yaml"
        p.write_text(text)
        return read_config(str(p), cmd, section)


@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_written_configs_read_back_as_given(data):
    """What --write-config writes (config_text) reads back (read_config) as the values' text."""
    cmd = _command("selfcal")
    options = [p for p in cmd.params if isinstance(p, click.Option) and p.name not in ("config", "write_config")]
    chosen = data.draw(st.lists(st.sampled_from(options), unique_by=lambda p: p.name, max_size=8))
    values = {}
    for p in chosen:
        if p.is_flag:
            values[p.name] = data.draw(st.booleans())
        elif isinstance(p.type, (click.types.FloatParamType, click.types.IntParamType)):
            values[p.name] = data.draw(
                st.integers(0, 10**6)
                if isinstance(p.type, click.types.IntParamType)
                else st.floats(0, 1e6, allow_nan=False)
            )
        else:
            values[p.name] = data.draw(st.text(alphabet="abcdefghij/_-.,0123456789 :#'\"", min_size=1, max_size=20))
    got = read_config_text(config_text("selfcal", values), cmd, "selfcal")
    multiple = {p.name for p in chosen if p.multiple}  # a repeatable option's values: a,b
    expect = {
        k: (v if isinstance(v, bool) else tuple(x.strip() for x in v.split(",")) if k in multiple else str(v))
        for k, v in values.items()
    }
    assert got.keys() == expect.keys()
    for k, v in expect.items():
        if isinstance(v, bool):
            assert got[k] is v
        elif isinstance(values[k], float):
            assert float(got[k]) == values[k]
        else:
            assert got[k] == v
