"""``semexp-bt export DIR --mcap OUT.mcap``: a saved mission view as an MCAP file of ROS 2 messages
(images, odometry, twist, TF, the map, the memory as markers) for Foxglove, Lichtblick and ``ros2 bag``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "recording", type=Path, help="a directory written by `semexp-bt run --view-record DIR`"
    )
    parser.add_argument("--mcap", type=Path, required=True, metavar="OUT.mcap", help="the MCAP file to write")


def run(args: argparse.Namespace) -> int:
    from semexp_bt.app.viewer.recording import RecordingError

    try:
        from semexp_bt.app.viewer.mcap_export import export_mcap

        summary = export_mcap(args.recording, args.mcap)
    except RecordingError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except ModuleNotFoundError as exc:
        print(
            f"error: the export needs the viewer extra (pip install -e '.[viewer]'): {exc}", file=sys.stderr
        )
        return 2
    total = sum(summary.messages.values())
    print(f"{summary.path}: {total} messages")
    for topic, count in summary.messages.items():
        print(f"  {topic:22s} {count}")
    return 0
