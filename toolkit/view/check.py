"""`make view-check`: render a saved run (.rrd) in Rerun's web viewer in headless Chromium, save a screenshot.

The rerun-sdk wheel ships the ``rerun`` program with its web viewer built in: ``rerun --web-viewer``
serves the viewer over HTTP and the recording over gRPC, both on this machine only. Chromium (the
Debian package) opens the page headless, drawing with its software rasteriser (SwiftShader), driven
by Playwright; the screenshot is taken once two frames two seconds apart are the same and the page
shows the viewer (not its loading screen).

The viewer program is started directly (not through the ``rerun`` script on PATH, a Python wrapper
that leaves its child running when it is stopped), in a session of its own, and its whole process
group is ended afterwards, on success or failure; `screenshot` checks that the group is gone.

Usage: ``python tools/view_check.py RUN.rrd [OUT.png]`` (``make view-check``; OUT.png defaults to
``out/rerun-view.png``)
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import time
import urllib.parse
import urllib.request
from pathlib import Path

from .viewer import stop_group, viewer_binary

__all__ = ["DEFAULT_PNG", "group_alive", "screenshot"]

DEFAULT_PNG = Path("out") / "rerun-view.png"
"""Where `make view-check` writes the screenshot (untracked); docs/img/rerun-view.png only when asked."""

CHROMIUM_ARGS = ["--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--ignore-gpu-blocklist"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait_http(url: str, timeout_s: float) -> None:
    end = time.monotonic() + timeout_s
    while True:
        try:
            with urllib.request.urlopen(url, timeout=2.0):
                return
        except OSError:
            if time.monotonic() > end:
                raise RuntimeError(f"the Rerun web viewer did not answer at {url} in {timeout_s:g} s") from None
            time.sleep(0.2)


def group_alive(pgid: int) -> bool:
    """Whether any process of the process group `pgid` is still there (a zombie counts as gone)."""
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue  # ended while we looked
        if int(fields[2]) == pgid and fields[0] != "Z":
            return True
    return False


def screenshot(rrd: Path, png: Path = DEFAULT_PNG, *, size: tuple[int, int] = (1280, 800),
               timeout_s: float = 120.0) -> None:
    """Serve `rrd` with ``rerun --web-viewer``, open it in headless Chromium and save `png`.

    Parameters
    ----------
    rrd : Path
        A Rerun recording (``nxtnav run --view-save``).
    png : Path
        The screenshot to write.
    size : (int, int)
        The page's width and height (px).
    timeout_s : float
        How long the page may take to settle (s).

    Raises
    ------
    RuntimeError
        No chromium, a viewer that does not answer or settle, or a viewer process left behind.
    """
    from playwright.sync_api import sync_playwright

    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        raise RuntimeError("no chromium on PATH (Debian: apt-get install chromium)")
    web, grpc = _free_port(), _free_port()
    argv = [str(viewer_binary("view-check")), "--web-viewer", "--bind", "127.0.0.1", "--web-viewer-port", str(web),
            "--port", str(grpc), "--hide-welcome-screen", str(rrd)]
    server = subprocess.Popen(argv,
                              stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              start_new_session=True)
    try:
        page_url = f"http://127.0.0.1:{web}/"
        _wait_http(page_url, 30.0)
        data = urllib.parse.quote(f"rerun+http://127.0.0.1:{grpc}/proxy", safe="")
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, headless=True, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": size[0], "height": size[1]})
            page.goto(f"{page_url}?url={data}")
            end = time.monotonic() + timeout_s
            last = b""
            while True:
                page.wait_for_timeout(2000)
                shot = page.screenshot()
                loading = page.get_by_text("Loading").count() > 0
                if shot == last and not loading:
                    break
                if time.monotonic() > end:
                    raise RuntimeError(f"the viewer did not settle in {timeout_s:g} s")
                last = shot
            browser.close()
        png.parent.mkdir(parents=True, exist_ok=True)
        png.write_bytes(last)
    finally:
        stop_group(server)
        if os.name == "posix" and Path("/proc/self/stat").exists() and group_alive(server.pid):
            raise RuntimeError(f"the Rerun viewer's process group {server.pid} is still running")
