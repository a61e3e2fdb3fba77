"""Rerun streams for a run: `open_stream` (a viewer or an .rrd file), `LiveView` (a `Recorder` listener) and
`view_file` (a recording or an exported MCAP bag)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..timeline import Item, RunInfo, Timeline, timeline_of
from ..world import NxtnavError

__all__ = ["LiveView", "open_stream", "view_file"]

APPLICATION = "nxtnav"


def open_stream(save: Path | None) -> Any:
    """A Rerun recording stream that writes `save` (an .rrd file), or, without one, a spawned viewer."""
    try:
        import rerun as rr
    except ImportError:
        raise NxtnavError("the view needs Rerun: install the 'viz' extra (pip install -e '.[viz]')") from None
    stream = rr.RecordingStream(APPLICATION)
    if save is not None:
        save.parent.mkdir(parents=True, exist_ok=True)
        stream.save(str(save))
    else:
        stream.spawn()
    return stream


def close_stream(stream: Any) -> None:
    """Write out everything logged and close the stream's sinks (the .rrd file is complete after this)."""
    stream.flush()
    stream.disconnect()


class LiveView:
    """A `toolkit.recording.Recorder` listener that draws each line as it is written."""

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
        from ..ros2_export.reader import timeline_of_bag

        return timeline_of_bag(path)
    return timeline_of(path)


def view_file(path: Path, save: Path | None) -> int:
    """Draw a recording (REC.jsonl) or an exported bag (a rosbag2 folder) in a viewer or into `save`;
    returns the number of items drawn. The input is read whole before any viewer starts."""
    from .scene import RerunScene

    info, items = _load(path)
    stream = open_stream(save)
    scene = RerunScene(stream)
    scene.start(info)
    for item in items:
        scene.log(item)
    close_stream(stream)
    return len(items)
