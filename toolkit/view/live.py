"""Rerun streams for a run: `open_stream` (a viewer or an .rrd file), `LiveView` (a `Recorder` listener) and
`view_file` (a recording or an exported MCAP bag)."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from ..recordings.timeline import Item, RunInfo, Timeline, timeline_of
from .viewer import check_view, start_viewer

__all__ = ["LiveView", "open_stream", "view_file"]

APPLICATION = "nxtnav"
"""The application id of every stream (what the viewer lists the recordings under)."""

FLUSH_TIMEOUT_S = 30.0
"""How long the end of a run waits for a viewer to take the data still on its way (s)."""

logger = logging.getLogger(__name__)


def open_stream(save: Path | None, *, what: str = "view", save_option: str = "--save") -> Any:
    """A Rerun recording stream that writes `save` (an .rrd file), or, without one, streams to a new viewer.

    Parameters
    ----------
    save : Path or None
        The .rrd file to write; None opens a viewer (`toolkit.view.viewer.start_viewer`).
    what, save_option : str
        The option or command asking for the view and the one that writes a file instead, named in
        the one-line errors (no Rerun, no display, no viewer program, a viewer that quits at start).
    """
    binary = check_view(what, save_option, spawn=save is None)
    import rerun as rr

    stream = rr.RecordingStream(APPLICATION)
    if save is not None:
        save.parent.mkdir(parents=True, exist_ok=True)
        stream.save(str(save))
    else:
        assert binary is not None
        stream.connect_grpc(start_viewer(binary, what, save_option))
    return stream


def close_stream(stream: Any, timeout_s: float = FLUSH_TIMEOUT_S) -> None:
    """Write out everything logged and close the stream's sinks (the .rrd file is complete after this).

    A viewer closed before the end gets a warning, not an error: the run's own results stand.
    `timeout_s` bounds the wait for a viewer to take the rest (s)."""
    try:
        stream.flush(timeout_sec=timeout_s)
    except RuntimeError as exc:
        logger.warning("the Rerun viewer did not take the whole run (closed?): %s", " ".join(str(exc).split()))
    stream.disconnect()


class LiveView:
    """A `toolkit.recordings.recorder.Recorder` listener that draws each line as it is written."""

    def __init__(self, stream: Any) -> None:
        from .scene import RerunScene

        self.scene = RerunScene(stream)
        self.timeline = Timeline()

    def __call__(self, event: dict[str, Any]) -> None:
        items = self.timeline.feed(event)
        if event["type"] == "header":
            assert self.timeline.info is not None
            self.scene.start(self.timeline.info)
        for item in items:
            self.scene.log(item)


def _load(path: Path) -> tuple[RunInfo, list[Item]]:
    if path.is_dir():
        from ..ros.export.reader import timeline_of_bag

        return timeline_of_bag(path)
    return timeline_of(path)


def view_file(path: Path, save: Path | None) -> int:
    """Draw a recording (REC.jsonl) or an exported bag (a rosbag2 folder) in a viewer or into `save`;
    returns the number of items drawn. The input is read whole before any viewer starts."""
    check_view("view", "--save", spawn=save is None)
    from .scene import RerunScene

    info, items = _load(path)
    stream = open_stream(save)
    scene = RerunScene(stream)
    scene.start(info)
    for item in items:
        scene.log(item)
    close_stream(stream)
    return len(items)
