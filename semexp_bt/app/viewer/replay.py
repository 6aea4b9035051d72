"""Replaying a saved recording: the tree page over the saved ticks, Rerun over the saved ``world.rrd``."""

from __future__ import annotations

from pathlib import Path

from semexp_bt.app.viewer.recording import SavedRecording, open_recording
from semexp_bt.app.viewer.tree_page import WORLD_ROUTE, TickFeed, ViewServer


def serve_recording(
    directory: Path, *, host: str = "127.0.0.1", port: int = 0
) -> tuple[ViewServer, SavedRecording]:
    """Serve the saved recording in ``directory`` (checked first) and return the server and the recording.

    Raises:
        RecordingError: naming the file (and line) of a missing or malformed part.
    """
    recording = open_recording(directory)
    manifest = recording.manifest
    world = None
    if recording.world_path is not None:
        world = {"kind": "rrd", "url": WORLD_ROUTE, "recording_id": manifest.get("recording_id")}
    feed = TickFeed(
        {
            "mode": "replay",
            "title": manifest.get("title", str(directory)),
            "tree": recording.tree,
            "world": world,
            "outcome": manifest.get("outcome"),
            "complete": recording.complete,
            "frames": manifest.get("frames"),
        },
        recording.tick_lines,
        done=True,
    )
    server = ViewServer(feed, world_file=recording.world_path, host=host, port=port)
    return server, recording
