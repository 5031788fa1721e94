"""A fork server for the documentation's commands: ``umbmark`` without its start-up per command.

The pages hold over a hundred commands, and each fresh ``python -m umbmark`` spends most of its
time importing numpy, scipy and numba and loading the compiled kernels. This server does that
once, then forks a child per command: the child takes the caller's standard streams (passed
over a Unix socket), working folder, environment and arguments, runs ``umbmark.cli.main`` as
the console script does, and reports its exit status. Each command thus runs in its own process
from the same clean state, as from a shell. The commands' own start-up (a fresh interpreter per
command) is tested by the start-up tests (``tests/test_cli_help.py``).

``python tests/cli_server.py SOCKET`` serves until killed; :func:`client_script` is the text of
the ``umbmark`` a shell then runs.
"""

from __future__ import annotations

import array
import json
import os
import signal
import socket
import struct
import sys

READY = b"ready\n"


def _warm() -> None:
    """Import every command and load the compiled kernels, so that the children inherit them."""
    import click

    from umbmark.cli import app

    ctx = click.Context(app)
    for name in app.list_commands(ctx):
        app.get_command(ctx, name)
    here = os.path.dirname(os.path.abspath(__file__))
    warm = os.path.join(here, os.pardir, ".ci", "warm_numba.py")
    with open(warm, encoding="utf-8") as f:
        exec(compile(f.read(), warm, "exec"), {"__name__": "__warm__"})


def _recv(conn: socket.socket) -> tuple[dict, list[int]]:
    fds = array.array("i")
    data = b""
    while not data.endswith(b"\n"):
        msg, anc, _, _ = conn.recvmsg(1 << 20, socket.CMSG_SPACE(3 * fds.itemsize))
        if not msg:
            raise EOFError
        for level, kind, payload in anc:
            if level == socket.SOL_SOCKET and kind == socket.SCM_RIGHTS:
                fds.frombytes(payload[: len(payload) - len(payload) % fds.itemsize])
        data += msg
    return json.loads(data), list(fds)


def _child(conn: socket.socket, request: dict, fds: list[int]) -> None:
    signal.signal(signal.SIGCHLD, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    code = 70
    try:
        for target, fd in enumerate(fds):
            os.dup2(fd, target)
            os.close(fd)
        os.chdir(request["cwd"])
        os.environ.clear()
        os.environ.update(request["env"])
        sys.argv = ["umbmark", *request["argv"]]
        from umbmark.cli import main

        code = main(request["argv"])
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else 1
    except BaseException:
        import traceback

        traceback.print_exc()
        code = 70
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:
                pass
        try:
            conn.sendall(struct.pack("!i", code))
        finally:
            os._exit(code)


def serve(path: str) -> None:
    _warm()
    signal.signal(signal.SIGCHLD, signal.SIG_IGN)  # the children are reaped by the kernel
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(path)
    server.listen(64)
    sys.stdout.buffer.write(READY)
    sys.stdout.flush()
    while True:
        conn, _ = server.accept()
        try:
            request, fds = _recv(conn)
        except (EOFError, ValueError, OSError):
            conn.close()
            continue
        if os.fork() == 0:
            server.close()
            _child(conn, request, fds)
        for fd in fds:
            os.close(fd)
        conn.close()


CLIENT = r'''#!{python} -S
"""umbmark through the fork server of the documentation tests (tests/cli_server.py)."""
import json, os, socket, struct, sys
s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
s.connect({path!r})
msg = json.dumps({{"argv": sys.argv[1:], "cwd": os.getcwd(), "env": dict(os.environ)}}).encode() + b"\n"
socket.send_fds(s, [msg], [0, 1, 2])
data = b""
while len(data) < 4:
    part = s.recv(4 - len(data))
    if not part:
        sys.stderr.write("umbmark: the command's process ended without a status\n")
        sys.exit(70)
    data += part
sys.exit(struct.unpack("!i", data)[0])
'''


def client_script(path: str) -> str:
    """The text of an ``umbmark`` executable that runs its command through the server at ``path``."""
    return CLIENT.format(python=sys.executable, path=path)


if __name__ == "__main__":
    serve(sys.argv[1])
