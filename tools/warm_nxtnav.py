"""A warm `nxtnav` for the documented commands: the imports done once, a fork of them for every call.

Each ``nxtnav`` process spends one to two seconds importing the toolkit and its numerical libraries
(numba's first kernel among them) before its work; the documented commands of README.md and docs/
start well over a hundred of them. `tools/docs_commands.py` runs its blocks with a stand-in ``nxtnav``
first on PATH that hands its command line, folder, environment and standard streams (the descriptors
themselves, over a Unix socket) to a server which has imported everything once; the server forks, and
the child runs the console script's own entry point (`toolkit.cli.main`, sys.argv as typed) in that
folder, with that environment and those streams, in a session of its own. The stand-in waits for the
child and exits as it did (the same code, or the same signal); a signal sent to the stand-in (``kill
%1``, Ctrl-C) goes to the child, and a stand-in that dies takes its child with it. When the child
ends, whatever it left running in its session ends too (a real command's leftovers end with the
block's process group).

What differs from a fresh process is only what the imports leave behind: modules already loaded, and
numba's compiled kernels already in memory. ``NXTNAV_DOCS_WARM=0`` runs every block with the real
console script instead; the wheel's fresh install (``make dist-check``) and the suite's subprocess
tests start real processes.

    python tools/warm_nxtnav.py serve SOCKET     # what `start_server` runs
"""

from __future__ import annotations

import json
import os
import selectors
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

SOCKET_ENV = "NXTNAV_WARM_SOCKET"
HEADER = struct.Struct("!I")
STATUS = struct.Struct("!i")
START_TIMEOUT_S = 120.0

# the stand-in: started for every `nxtnav` of a block, so it imports nothing beyond the standard library's
# socket and json, without site-packages (-S); with no server it becomes the real console script
SHIM = '''#!{python} -IS
import json, os, signal, socket, struct, sys
real = "{real}"
try:
    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    conn.connect(os.environ["{socket_env}"])
except (KeyError, OSError):
    os.execv(real, [real, *sys.argv[1:]])
def exactly(n):
    data = b""
    while len(data) < n:
        part = conn.recv(n - len(data))
        if not part:
            sys.stderr.write("nxtnav: the warm nxtnav server went away\\n")
            os._exit(1)
        data += part
    return data
streams = []
for fd in (0, 1, 2):
    try:
        os.fstat(fd)
        streams.append(fd)
    except OSError:
        streams.append(os.open(os.devnull, os.O_RDWR))
payload = json.dumps({{"argv": sys.argv[1:], "cwd": os.getcwd(), "env": dict(os.environ)}}).encode()
socket.send_fds(conn, [struct.pack("!I", len(payload)) + payload], streams)
child = struct.unpack("!i", exactly(4))[0]
for number in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT, signal.SIGUSR1, signal.SIGUSR2):
    signal.signal(number, lambda n, frame: os.kill(child, n))
code = struct.unpack("!i", exactly(4))[0]
if code < 0:
    signal.signal(-code, signal.SIG_DFL)
    os.kill(os.getpid(), -code)
os._exit(code)
'''


def _preload() -> None:
    """Import what the commands import, and run one compiled kernel (numba's first call readies its
    compiler's registries, a few tenths of a second in every fresh process)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot
    import numpy as np

    import localisation  # noqa: F401
    import planners  # noqa: F401
    import toolkit.bench
    import toolkit.mission
    import toolkit.real_sonar  # noqa: F401
    from toolkit.cli import _load
    from toolkit.world import NxtSonar, load_map

    _load()
    square = load_map("map1")
    NxtSonar().echo_distance(square.walls, np.array([[20.0, 20.0]]), np.zeros(1))
    square.is_free(np.array([[20.0, 20.0]]), 5.0)


def _receive(conn: socket.socket) -> tuple[dict[str, Any], list[int]]:
    """The stand-in's request (a length, then JSON) and the descriptors that came with its first bytes."""
    data, fds, _, _ = socket.recv_fds(conn, 1 << 16, 3)
    data = _exactly(conn, data, HEADER.size)
    (size,) = HEADER.unpack(data[: HEADER.size])
    return json.loads(_exactly(conn, data, HEADER.size + size)[HEADER.size :]), list(fds)


def _exactly(conn: socket.socket, data: bytes, n: int) -> bytes:
    """`data` read on from `conn` until it holds `n` bytes."""
    while len(data) < n:
        part = conn.recv(n - len(data))
        if not part:
            raise OSError("the stand-in closed its connection")
        data += part
    return data


def _run_child(request: dict[str, Any], fds: list[int]) -> None:
    """In the forked child: become the command the stand-in was asked to be, then exit as it does."""
    os.setsid()
    for target, fd in enumerate(fds):
        os.dup2(fd, target)
        os.close(fd)
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update(request["env"])
    sys.argv = ["nxtnav", *request["argv"]]
    for number in (signal.SIGTERM, signal.SIGHUP, signal.SIGCHLD, signal.SIGQUIT, signal.SIGUSR1, signal.SIGUSR2):
        signal.signal(number, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    code = 1
    try:
        from toolkit.cli import main

        main()  # the console script's path: it flushes and leaves with os._exit
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except BaseException:
        import traceback

        traceback.print_exc()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def serve(path: str) -> None:
    """Preload, listen on the Unix socket `path`, and fork a child per stand-in until SIGTERM or until the
    process that started it is gone; the children still running then go with it."""
    parent = os.getppid()
    signal.signal(signal.SIGTERM, lambda number, frame: sys.exit(0))
    _preload()
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(path + ".tmp")
    listener.listen(64)
    os.replace(path + ".tmp", path)  # the socket appears once the imports are done
    selector = selectors.DefaultSelector()
    selector.register(listener, selectors.EVENT_READ)
    children: dict[int, socket.socket] = {}
    try:
        _serve(listener, selector, children, parent)
    finally:
        for pid in children:
            _end_group(pid)


def _end_group(pid: int) -> None:
    """SIGKILL to the process group of the child `pid` (its own session): it and whatever it started and
    left there, as the block's end stops what a real command left in the block's group."""
    try:
        os.killpg(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def _serve(listener: socket.socket, selector: selectors.BaseSelector, children: dict[int, socket.socket],
           parent: int) -> None:
    while os.getppid() == parent:
        for key, _ in selector.select(timeout=0.02):
            if key.fileobj is listener:
                _start(listener, selector, children)
            else:  # a stand-in closed its end early: it died, so its child goes too
                pid = key.data
                try:
                    if not key.fileobj.recv(1):  # type: ignore[union-attr]
                        _end_group(pid)
                        selector.unregister(key.fileobj)
                except OSError:
                    selector.unregister(key.fileobj)
        _reap(selector, children)


def _start(listener: socket.socket, selector: selectors.BaseSelector, children: dict[int, socket.socket]) -> None:
    conn, _ = listener.accept()
    try:
        request, fds = _receive(conn)
    except (OSError, ValueError):
        conn.close()
        return
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:
        listener.close()
        conn.close()
        for other in children.values():
            other.close()
        _run_child(request, fds)
    for fd in fds:
        os.close(fd)
    conn.sendall(STATUS.pack(pid))
    children[pid] = conn
    selector.register(conn, selectors.EVENT_READ, pid)


def _reap(selector: selectors.BaseSelector, children: dict[int, socket.socket]) -> None:
    while children:
        try:
            pid, status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return
        _end_group(pid)  # what the command left running (pool workers, a cluster) goes with it
        conn = children.pop(pid, None)
        if conn is None:
            continue
        try:
            selector.unregister(conn)
        except (KeyError, ValueError):
            pass
        try:
            conn.sendall(STATUS.pack(os.waitstatus_to_exitcode(status)))
        except OSError:
            pass
        conn.close()


class WarmServer:
    """A running server and the folder of its stand-in; `environment` puts the stand-in first on PATH."""

    def __init__(self, env: dict[str, str]) -> None:
        self.folder = Path(tempfile.mkdtemp(prefix="nxtnav-warm-"))
        self.socket = str(self.folder / "socket")
        real = Path(sys.executable).parent / "nxtnav"
        shim = self.folder / "bin" / "nxtnav"
        shim.parent.mkdir()
        shim.write_text(SHIM.format(python=sys.executable, real=real, socket_env=SOCKET_ENV))
        shim.chmod(0o755)
        self.process = subprocess.Popen([sys.executable, __file__, "serve", self.socket], env=env,
                                        stdin=subprocess.DEVNULL, start_new_session=True)
        deadline = time.monotonic() + START_TIMEOUT_S
        while not os.path.exists(self.socket):
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"the warm nxtnav server did not start (exit {self.process.poll()})")
            time.sleep(0.05)

    def environment(self, env: dict[str, str]) -> dict[str, str]:
        out = dict(env)
        out["PATH"] = os.pathsep.join([str(self.folder / "bin"), env.get("PATH", "")])
        out[SOCKET_ENV] = self.socket
        return out

    def stop(self) -> None:
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGTERM)
            self.process.wait()
        for leftover in (self.folder / "bin" / "nxtnav", Path(self.socket)):
            leftover.unlink(missing_ok=True)
        (self.folder / "bin").rmdir()
        self.folder.rmdir()


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] != "serve":
        sys.exit("usage: python tools/warm_nxtnav.py serve SOCKET")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    serve(sys.argv[2])
