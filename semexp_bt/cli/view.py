"""``semexp-bt view DIR``: replay a saved mission view in the browser (the tree and Rerun's world view,
moving together when scrubbed). ``DIR`` is written by ``semexp-bt run ... --view-record DIR``."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "recording", type=Path, help="a directory written by `semexp-bt run --view-record DIR`"
    )
    parser.add_argument("--port", type=int, default=0, help="the page's port (default: a free one)")
    parser.add_argument("--host", default="127.0.0.1", help="the interface to serve on (default: loopback)")
    parser.add_argument("--no-browser", action="store_true", help="print the URL only; open no browser")


def run(args: argparse.Namespace) -> int:
    from semexp_bt.app.viewer.recording import RecordingError
    from semexp_bt.app.viewer.replay import serve_recording

    try:
        server, recording = serve_recording(args.recording, host=args.host, port=args.port)
    except RecordingError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"error: cannot serve on {args.host}:{args.port}: {exc}", file=sys.stderr)
        return 2
    if not recording.complete:
        print(
            "warning: this recording was cut short (the mission did not end while recording)", file=sys.stderr
        )
    if recording.world_path is None:
        print("note: no world recording in this directory; the page shows the tree only", file=sys.stderr)
    print(f"view: {server.url}  ({len(recording.tick_lines)} ticks; Ctrl-C to stop)", flush=True)
    if not args.no_browser:
        server.open_browser()
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
    return 0
