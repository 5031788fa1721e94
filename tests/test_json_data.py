"""``--json`` prints data as stored: the CLI's wording of messages (library names turned into
flags) applies to messages only, never to a robot's name, a path or a note."""

import contextlib
import io
import json

from umbmark.cli import main
from umbmark.cli.app import _cli_strings


def _run(args):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(args)
    assert rc == 0, err.getvalue()
    return out.getvalue()


def test_a_robot_named_like_a_message_is_printed_as_stored(tmp_path):
    db = str(tmp_path / "h.sqlite")
    name = "r`wheelbase_mm=5` `id`"
    d = json.loads(_run(["calibrate", "--seed", "1", "--robot", name, "--record", "--db", db, "--json"]))
    assert d["history"]["robot"] == name
    h = json.loads(_run(["history", name, "--db", db, "--json"]))
    assert h["robot"] == name and h["records"][0]["robot"] == name


def test_messages_still_name_the_flags_and_data_keys_are_kept():
    got = _cli_strings(
        {
            "warnings": ["check `wheelbase_mm`"],
            "robot": "`wheelbase_mm`",
            "inputs": [{"path": "a`wheelbase_mm`", "scan_topic": "/`x`", "warnings": ["`wheelbase_mm` off"]}],
        }
    )
    assert got["warnings"] == ["check --wheelbase-mm"] and got["robot"] == "`wheelbase_mm`"
    assert got["inputs"][0]["path"] == "a`wheelbase_mm`" and got["inputs"][0]["scan_topic"] == "/`x`"
    assert got["inputs"][0]["warnings"] == ["--wheelbase-mm off"]
