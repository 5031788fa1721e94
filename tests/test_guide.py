"""umbmark guide: the field procedure, step by step."""

from umbmark.cli import main
from umbmark.realrobot.guide import STEP_TITLES, guide_text


def test_guide_has_every_step_in_order():
    text = guide_text()
    pos = [text.index(f"{i}. {t}") for i, t in enumerate(STEP_TITLES, 1)]
    assert pos == sorted(pos)
    for needle in (
        "start frame",
        "perpendicular",
        "5 runs clockwise and 5 runs counter-clockwise",
        "x along the first leg",
        "y to the left",
        "front mark -> side wall",
        "back mark -> back wall",
        "umbmark measure",
        "umbmark analyze",
        "--record",
        "x_odo",
        "theta_odo",
    ):
        assert needle in text, needle
    assert max(len(line) for line in text.splitlines()) <= 100


def test_guide_cli_options(capsys):
    assert main(["guide", "--side-mm", "2000", "--runs", "7"]) == 0
    out = capsys.readouterr().out
    assert "2000 mm sides" in out and "7 runs clockwise and 7 runs counter-clockwise" in out
    assert main(["guide", "--side-mm", "-1"]) == 2
    assert "--side-mm must be a positive number" in capsys.readouterr().err
