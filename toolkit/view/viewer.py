"""The Rerun viewer program: find it, check that it can open a window, start it, stop it.

Rerun's own ``spawn`` looks for ``rerun`` on PATH, starts it and streams to it even when the viewer
died at once (no display): the data then waits in a gRPC buffer that nobody reads. Here the viewer is
started as a process of its own (its own session, so a Ctrl-C of the mission leaves the window open)
and watched until it listens on its port; a viewer that quits at start is one line naming its reason.

Nothing here imports ``rerun`` at module level, so the checks run (and fail) before any mission work.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path
from typing import IO

from ..world import NxtnavError

__all__ = ["INSTALL_HINT", "check_view", "display_problem", "require_rerun", "start_viewer", "stop_group",
           "viewer_binary"]

INSTALL_HINT = "pip install 'nxtnav[viz]' (in a clone of the repository: pip install -e '.[viz]')"
"""How to install the ``viz`` extra, for a wheel user and for a clone."""

DISPLAY_VARIABLES = ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET")
"""What the viewer's window library (winit) reads on Linux and the BSDs to reach a display server."""

START_TIMEOUT_S = 15.0
"""How long a starting viewer may take to listen on its port (s)."""

SETTLE_S = 1.0
"""How long a viewer that listens must stay up before it counts as started (s): it binds its port
before it opens its window, and a window that cannot open ends it within milliseconds."""

_ANSI = re.compile(r"\x1b\[[0-9;]*m")
_SOURCE_PLACE = re.compile(r" at \S+\.rs:\d+:")


def require_rerun(what: str) -> None:
    """Import ``rerun`` or raise `NxtnavError` saying how to install the ``viz`` extra.

    Parameters
    ----------
    what : str
        The option or command that needs Rerun (``--view``, ``nxtnav view``), named in the message.
    """
    try:
        importlib.import_module("rerun")
    except ImportError:
        raise NxtnavError(f"{what} needs Rerun (the 'viz' extra), which is not installed: {INSTALL_HINT}") from None


def display_problem(env: Mapping[str, str] | None = None, platform: str | None = None) -> str | None:
    """Why the viewer cannot open a window here, or None when it can try.

    Parameters
    ----------
    env : mapping, optional
        The environment (default: ``os.environ``).
    platform : str, optional
        ``sys.platform`` (default: this machine's). macOS and Windows always have a window system.
    """
    env = os.environ if env is None else env
    platform = sys.platform if platform is None else platform
    if not platform.startswith(("linux", "freebsd", "openbsd", "netbsd")):
        return None
    if any(env.get(name) for name in DISPLAY_VARIABLES):
        return None
    return f"no display for the Rerun viewer ({', '.join(DISPLAY_VARIABLES)} all unset)"


def viewer_binary(what: str = "the view") -> Path:
    """The Rerun viewer program: ``RERUN_CLI_PATH`` when set, else the one in the rerun-sdk wheel
    (package ``rerun_cli``), else ``rerun`` on PATH.

    Parameters
    ----------
    what : str
        The option or command that needs the viewer, named in the message.

    Raises
    ------
    NxtnavError
        When none of these exists.
    """
    suffix = ".exe" if sys.platform.startswith("win") else ""
    override = os.environ.get("RERUN_CLI_PATH")
    if override:
        if not Path(override).is_file():
            raise NxtnavError(f"{what}: RERUN_CLI_PATH names {override}, which is not a file: unset it or point it at "
                              "the rerun program")
        return Path(override)
    spec = importlib.util.find_spec("rerun_cli")
    looked: list[str] = []
    if spec is not None and spec.origin is not None:
        folder = Path(spec.origin).parent
        for candidate in (folder / "Rerun.app" / "Contents" / "MacOS" / "Rerun", folder / f"rerun{suffix}"):
            if candidate.is_file():
                return candidate
        looked.append(str(folder / f"rerun{suffix}"))
    on_path = shutil.which("rerun")
    if on_path is not None:
        return Path(on_path)
    looked.append("rerun on PATH")
    raise NxtnavError(f"{what}: the Rerun viewer program is missing (looked for {' and '.join(looked)}); "
                      f"reinstall the 'viz' extra: {INSTALL_HINT}")


def check_view(what: str, save_option: str, *, spawn: bool) -> Path | None:
    """Everything a view needs, checked before any work: Rerun, and to open a viewer, a display and
    the viewer program (returned; None when the view goes to a file).

    Parameters
    ----------
    what : str
        The option or command asking for the view, named in the messages (``--view``, ``view``).
    save_option : str
        The option that writes the view to a file instead (``--view-save``, ``--save``), suggested
        when no viewer can open.
    spawn : bool
        Whether a viewer is to be opened (False: the view goes to a file).
    """
    require_rerun(what)
    if not spawn:
        return None
    problem = display_problem()
    if problem is not None:
        raise NxtnavError(f"{what}: {problem}; write the view with {save_option} FILE.rrd and open it where "
                          "there is a screen (rerun FILE.rrd) or in a browser (rerun --web-viewer FILE.rrd)")
    return viewer_binary(what)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _listens(port: int) -> bool:
    with socket.socket() as s:
        s.settimeout(0.2)
        return s.connect_ex(("127.0.0.1", port)) == 0


def _reason(log: IO[bytes]) -> str:
    """The viewer's last error line (colour codes and source places removed), or its last line."""
    log.seek(0)
    lines = [" ".join(_ANSI.sub("", ln).split()) for ln in log.read().decode(errors="replace").splitlines()]
    lines = [ln for ln in lines if ln]
    errors = [ln for ln in lines if ln.startswith("Error")]
    text = (errors or lines or ["no message"])[-1]
    return _SOURCE_PLACE.sub("", text)


def stop_group(proc: subprocess.Popen[bytes], timeout_s: float = 10.0) -> None:
    """End `proc` and every process of its group (`proc` must lead one: ``start_new_session=True``).

    SIGTERM to the group, up to `timeout_s` (s) for the leader to end, then SIGKILL to whatever is
    left in the group (a leader that would not end, or a child it started)."""
    for sig, wait_s in ((signal.SIGTERM, timeout_s), (signal.SIGKILL, None)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            pass  # the group is empty
        try:
            proc.wait(timeout=wait_s)
        except subprocess.TimeoutExpired:
            pass


def start_viewer(binary: Path, what: str, save_option: str, *, timeout_s: float = START_TIMEOUT_S) -> str:
    """Start the viewer `binary` on a free local port in a session of its own; its gRPC address.

    The viewer stays open after nxtnav ends. Its log goes to an unnamed temporary file, read only
    to name the reason when it quits at start.

    Raises
    ------
    NxtnavError
        When the viewer quits at start (its reason in the message) or does not listen in `timeout_s`.
    """
    port = _free_port()
    log = tempfile.TemporaryFile()
    argv = [str(binary), "--bind", "127.0.0.1", "--port", str(port), "--memory-limit", "75%",
            "--hide-welcome-screen", "--expect-data-soon"]
    try:
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=log, stderr=log, start_new_session=True,
                                env={**os.environ, "RERUN_APP_ONLY": "true"})
    except OSError as exc:
        raise NxtnavError(f"{what}: cannot start the Rerun viewer {binary} ({exc.strerror or exc})") from None
    end = time.monotonic() + timeout_s
    listening_since: float | None = None
    while proc.poll() is None:
        now = time.monotonic()
        if listening_since is None and _listens(port):
            listening_since = now
        if listening_since is not None and now - listening_since >= SETTLE_S:
            log.close()  # the viewer keeps writing to its own handle of the unnamed file
            return f"rerun+http://127.0.0.1:{port}/proxy"
        if now > end:
            stop_group(proc)
            raise NxtnavError(f"{what}: the Rerun viewer {binary} did not listen on port {port} in "
                              f"{timeout_s:g} s; write the view with {save_option} FILE.rrd instead")
        time.sleep(0.05)
    reason = _reason(log)
    log.close()
    raise NxtnavError(f"{what}: the Rerun viewer quit at start (exit {proc.returncode}): {reason}; write the view "
                      f"with {save_option} FILE.rrd and open it where there is a screen (docs/recording.md)")
