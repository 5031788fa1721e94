"""Database URLs never show a password: in messages, in the JSON of a recorded result, in the
records themselves. Masked through the URL parser (credentials split at the last ``@`` before
the host; query parameters named like passwords)."""

import json
import subprocess
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from umbmark.cli import main
from umbmark.history import History, display_db, record_result
from umbmark.history.base import mask_secrets

pytest.importorskip("sqlalchemy", reason="SQLAlchemy not installed (optional extra 'db')")

# (URL, how messages show it)
CASES = [
    ("postgresql://user:p@ss@host/db", "postgresql://user:***@host/db"),
    ("postgresql://host/db?user=u&password=S3cr3tPW", "postgresql://host/db?user=u&password=***"),
    ("sqlite://user:pw@/x.sqlite", "sqlite://user:***@/x.sqlite"),
    (
        "postgresql+psycopg://u:pw@h:5432/db?sslmode=require&token=abc",
        "postgresql+psycopg://u:***@h:5432/db?sslmode=require&token=***",
    ),
    ("postgresql://u:p%40ss@h/db", "postgresql://u:***@h/db"),
    ("postgresql://u:p?ss@h/db", "postgresql://u:***@h/db"),
    ("postgresql://u:a/b@h/db", "postgresql://u:***@h/db"),
    ("postgresql://u:a@b?c@dbhost/umbmark", "postgresql://u:***@dbhost/umbmark"),
    (
        "postgresql://h/db?passwd=1&pwd=2&secret=3&token=4&api_key=5&PASSWORD=6&sslmode=require",
        "postgresql://h/db?passwd=***&pwd=***&secret=***&token=***&api_key=***&PASSWORD=***&sslmode=require",
    ),
    # nothing secret: shown as written (an "@" in a query value or a file path is not a credential)
    ("postgresql://u:pw@h/db?user=a@b.org", "postgresql://u:***@h/db?user=a@b.org"),
    ("postgresql://host:5432/db?user=a@b.org", "postgresql://host:5432/db?user=a@b.org"),
    (
        "postgresql+psycopg://umbmark@/t?host=/tmp/x&port=54329",
        "postgresql+psycopg://umbmark@/t?host=/tmp/x&port=54329",
    ),
    ("sqlite:////tmp/a@b/x.sqlite", "sqlite:////tmp/a@b/x.sqlite"),
    ("/tmp/h.sqlite", "/tmp/h.sqlite"),
]


@pytest.mark.parametrize(("url", "shown"), CASES)
def test_display_masks_every_form_of_password(url, shown):
    assert display_db(url) == shown


@settings(max_examples=300, deadline=None)
@given(
    st.from_regex(r"[a-z]{1,8}", fullmatch=True),
    st.text(st.characters(min_codepoint=33, max_codepoint=126), min_size=1, max_size=24),
)
def test_any_password_is_masked_whole(user, pw):
    """Any printable password, with @ : / ? % & = in it, disappears whole."""
    url = f"postgresql+psycopg://{user}:{pw}@dbhost:5432/umbmark?sslmode=require"
    assert display_db(url) == f"postgresql+psycopg://{user}:***@dbhost:5432/umbmark?sslmode=require"


@settings(max_examples=100, deadline=None)
@given(
    st.sampled_from(["password", "passwd", "pwd", "secret", "token", "api_key", "sslpassword", "Auth"]),
    st.from_regex(r"[A-Za-z0-9]{6,20}", fullmatch=True),
)
def test_secret_query_parameters_are_masked(key, value):
    shown = display_db(f"postgresql://dbhost/umbmark?user=u&{key}={value}&sslmode=require")
    assert value not in shown and f"{key}=***" in shown and "user=u" in shown and "sslmode=require" in shown


def test_urls_inside_any_message_are_masked():
    text = "cannot use postgresql://u:p@ss@h/db: refused (also sqlite://a:S3cr3t@/x.sqlite)."
    assert mask_secrets(text) == "cannot use postgresql://u:***@h/db: refused (also sqlite://a:***@/x.sqlite)."


@pytest.mark.parametrize(
    ("url", "secret"),
    [
        ("nosuchdialect://user:p@ss@host/db", "ss@"),
        ("postgresql+psycopg://127.0.0.1:1/db?user=u&password=S3cr3tPW", "S3cr3tPW"),
        ("postgresql+psycopg://user:p@ss@127.0.0.1:1/db", "ss@"),
        ("sqlite://user:S3cr3tPW@/missing.sqlite", "S3cr3tPW"),
    ],
)
def test_messages_never_show_the_password(url, secret, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["history", "--db", url]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and secret not in err and "***" in err, err
    monkeypatch.setenv("UMBMARK_DB", url)  # the same through the environment
    assert main(["history", "r1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and secret not in err and "***" in err, err
    assert not (tmp_path / "missing.sqlite").exists()  # reading created nothing


@pytest.mark.filterwarnings("ignore:Query string argument")  # SQLite's driver ignores the token
def test_recorded_result_and_records_hold_no_password(tmp_path, capsys, monkeypatch):
    """The JSON of --record names the database masked; a record's text fields store URLs masked."""
    from umbmark.io.runs_csv import write_runs_csv
    from umbmark.model.geometry import ErrorParams
    from umbmark.model.simulate import simulate_umbmark

    monkeypatch.chdir(tmp_path)
    write_runs_csv(simulate_umbmark(ErrorParams(1.002, 0.99), n_runs=5, noise="paper", seed=3), tmp_path / "runs.csv")
    url = "sqlite:///h.sqlite?token=S3cr3tPW"
    argv = ["analyze", "runs.csv", "--wheelbase-mm", "340", "--side-mm", "4000", "--robot", "r1", "--record"]
    assert main([*argv, "--db", url, "--json"]) == 0
    out = capsys.readouterr().out
    assert "S3cr3tPW" not in out and json.loads(out)["history"]["db"] == "sqlite:///h.sqlite?token=***"
    assert main(["history", "r1", "--db", url, "--json"]) == 0
    out = capsys.readouterr().out
    assert "S3cr3tPW" not in out and len(json.loads(out)["records"]) == 1

    db = tmp_path / "plain.sqlite"
    leaky = "postgresql://fleet:Hunter2pw@dbhost/umbmark"
    rid = record_result(
        "r1",
        kind="other",
        method=f"copied from {leaky}",
        results={"from": leaky, "nested": [{"db": leaky + "?token=Tok3nValue"}]},
        parameters={"c_left": 1.0, "c_right": 1.0, "Eb": 1.0},
        inputs={"paths": [leaky]},
        source=leaky,
        note=f"see {leaky}",
        db=db,
    )
    with History(db) as h:
        r = h.get(rid)
        h._conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    assert r.source == "postgresql://fleet:***@dbhost/umbmark"
    assert r.results["nested"][0]["db"] == "postgresql://fleet:***@dbhost/umbmark?token=***"
    assert r.inputs == {"paths": ["postgresql://fleet:***@dbhost/umbmark"]} and "***" in r.note and "***" in r.method
    raw = b"".join(p.read_bytes() for p in tmp_path.glob("plain.sqlite*"))
    assert b"Hunter2pw" not in raw and b"Tok3nValue" not in raw and b"fleet:***@dbhost" in raw


def test_masking_a_file_path_does_not_import_sqlalchemy():
    """Startup stays light: SQLAlchemy is imported only for a database URL."""
    code = (
        "import sys\nfrom umbmark.history import display_db\n"
        "assert display_db('/tmp/h.sqlite') == '/tmp/h.sqlite'\n"
        "from umbmark.cli import main\n"
        "print('sqlalchemy' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "False"


def test_a_password_with_at_signs_reaches_the_server(postgres_url):
    """``user:p@ss@host`` connects to the host with the password ``p@ss`` (SQLAlchemy's own parser
    would take ``ss@host`` for the host); the trust-authenticated test server ignores it."""
    from umbmark.history import open_history

    url = postgres_url.replace("://umbmark@", "://umbmark:p@ss@", 1)
    assert "://umbmark:p@ss@" in url
    rid = record_result("r1", kind="other", method="m", results={}, parameters={}, db=url)
    with open_history(url, create=False) as h:
        assert h.get(rid).robot == "r1" and "p@ss" not in h.path and "umbmark:***@" in h.path


def test_a_url_where_a_file_is_needed_is_named_masked():
    from umbmark.errors import InputError
    from umbmark.history import resolve_db_path

    with pytest.raises(InputError) as e:
        resolve_db_path("postgresql://user:p@ss@host/db")
    assert "postgresql://user:***@host/db" in str(e.value) and "ss@" not in str(e.value)
