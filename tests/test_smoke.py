from umbmark.cli import main


def test_help_lists_core_commands(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for cmd in ("simulate", "analyze", "demo"):
        assert cmd in out
