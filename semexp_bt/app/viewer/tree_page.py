"""The tree page: the mission tree drawn in the browser, tick by tick, beside Rerun's world view.

The page (``static/index.html``, ``viewer.js``, ``viewer.css``; no framework, nothing fetched from
outside) draws the tree as an outline: every node with its status colour, its feedback message, the
time it spent in its own tick, and the blackboard keys it wrote on that tick (from py_trees' activity
stream, attributed to the writing behaviour). A scrubber moves through the ticks; the Rerun viewer beside
it (the web viewer that ``rerun-notebook`` ships, driven through its widget interface) follows, and
scrubbing Rerun's own time panel moves the tree. One page serves both the live view of a running
mission and the replay of a saved one.

Why not py_trees' own renderer (``py-trees-js``): it ships its JavaScript inside a PyQt5 resource module
for a Qt web view, draws a tree top-down (45 nodes are a few thousand pixels wide) and has no notion of
per-node time or blackboard writes. The outline keeps every feedback message legible at full length and
is plain DOM, so a browser test can read it.

:class:`ViewServer` is a standard-library HTTP server on the loopback interface. Its routes:

- ``/`` the page, ``/static/*`` its script and style;
- ``/api/session`` the mode (``live`` or ``replay``), the title, the tree's structure and where the world
  view is (a gRPC URL for live, ``/world.rrd`` for a replay, or null);
- ``/api/ticks?after=N&limit=M`` the tick records after tick N (the page polls it while a mission runs);
- ``/rerun/*`` the Rerun web viewer (``rerun-notebook``'s ``widget.js`` and its WebAssembly), when the
  ``viewer`` extra is installed;
- ``/world.rrd`` the saved world recording (replay only).

A page that stops polling costs the mission nothing: the tick records wait in :class:`TickFeed`, and no
request handler runs on the tick thread.
"""

from __future__ import annotations

import importlib.util
import json
import threading
import webbrowser
from collections.abc import Sequence
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlparse

import py_trees

#: The page's own files.
STATIC_DIR = Path(__file__).resolve().parent / "static"
#: At most this many tick records per ``/api/ticks`` answer (a page catches up in a few requests).
TICKS_PER_REQUEST = 5000
#: The Rerun web viewer files the page loads, from ``rerun-notebook``'s package (name -> content type).
RERUN_ASSETS = {
    "widget.js": "text/javascript",
    "widget.css": "text/css",
    "re_viewer_bg.wasm": "application/wasm",
}
#: Where a replay's saved world recording is served.
WORLD_ROUTE = "/world.rrd"
#: How often the page's server looks for a request to stop (wall s): ``close`` waits up to this long.
#: ``socketserver``'s default, half a second, held every mission's end by 0.25 s on average (measured
#: 0.1 to 0.5 s); a look 20 times a second costs the mission nothing measurable.
SHUTDOWN_POLL_S = 0.05
#: The page may load and connect to this machine only: the Rerun viewer asks the internet for its latest
#: release on start, and the view promises that nothing is fetched from outside.
CONTENT_SECURITY_POLICY = (
    "default-src 'self'; script-src 'self' 'wasm-unsafe-eval'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data: blob:; font-src 'self' data:; worker-src 'self' blob:; "
    "connect-src 'self' http://127.0.0.1:* http://localhost:*"
)
_CONTENT_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript", ".css": "text/css"}


def node_kind(node: py_trees.behaviour.Behaviour) -> str:
    """``sequence``, ``selector``, ``parallel``, ``decorator`` or ``behaviour`` (a leaf)."""
    if isinstance(node, py_trees.composites.Sequence):
        return "sequence"
    if isinstance(node, py_trees.composites.Selector):
        return "selector"
    if isinstance(node, py_trees.composites.Parallel):
        return "parallel"
    if isinstance(node, py_trees.decorators.Decorator):
        return "decorator"
    return "behaviour"


def tree_structure(root: py_trees.behaviour.Behaviour) -> dict[str, Any]:
    """The tree as the page draws it: every node, depth first, with its type, kind, parent and children."""
    nodes: list[dict[str, Any]] = []

    def visit(node: py_trees.behaviour.Behaviour, parent: str | None, depth: int) -> None:
        nodes.append(
            {
                "name": node.name,
                "type": type(node).__name__,
                "kind": node_kind(node),
                "parent": parent,
                "depth": depth,
                "children": [child.name for child in node.children],
            }
        )
        for child in node.children:
            visit(child, node.name, depth + 1)

    visit(root, None, 0)
    return {"root": root.name, "nodes": nodes}


def rerun_assets_dir() -> Path | None:
    """Where ``rerun-notebook`` keeps the web viewer, or None without the ``viewer`` extra.

    The package is located, not imported: importing it starts Jupyter machinery the page does not need.
    """
    spec = importlib.util.find_spec("rerun_notebook")
    if spec is None or not spec.submodule_search_locations:
        return None
    static = Path(next(iter(spec.submodule_search_locations))) / "static"
    return static if all((static / name).is_file() for name in RERUN_ASSETS) else None


def world_view_available() -> bool:
    """Whether Rerun's SDK and its web viewer are installed (the ``viewer`` extra), found without importing
    either: the CLI asks before it spawns the view's world process, the observer before it starts."""
    return importlib.util.find_spec("rerun") is not None and rerun_assets_dir() is not None


class TickFeed:
    """The session the page shows, and its tick records as they arrive (thread-safe).

    Args:
        session: the ``/api/session`` answer (mode, title, tree, world).
        lines: tick records already known (a replay has them all).
        done: whether no more records will come.
    """

    def __init__(self, session: dict[str, Any], lines: Sequence[str] = (), *, done: bool = False) -> None:
        self._lock = threading.Lock()
        self._session = dict(session)
        self._lines: list[str] = list(lines)
        self._ticks: list[int] = [json.loads(line)["tick"] for line in self._lines]
        self._done = done

    def append(self, tick: int, line: str) -> None:
        """Add the record of ``tick`` (a JSON line)."""
        with self._lock:
            self._lines.append(line)
            self._ticks.append(tick)

    def update_session(self, **updates: Any) -> None:
        """Change parts of the session (the world's URL once the stream is served)."""
        with self._lock:
            self._session.update(updates)

    def finish(self, **session_updates: Any) -> None:
        """No more records; ``session_updates`` (e.g. the outcome) go into the session."""
        with self._lock:
            self._done = True
            self._session.update(session_updates)

    def session(self) -> dict[str, Any]:
        with self._lock:
            return {**self._session, "done": self._done, "ticks": len(self._lines)}

    def read(self, *, after: int, limit: int = TICKS_PER_REQUEST) -> tuple[list[str], bool]:
        """Records of the ticks after ``after`` (at most ``limit``), and whether the feed is done."""
        import bisect

        with self._lock:
            start = bisect.bisect_right(self._ticks, after)
            lines = self._lines[start : start + limit]
            done = self._done and start + len(lines) >= len(self._lines)
            return lines, done


class _Handler(BaseHTTPRequestHandler):
    server: _PageServer

    def log_message(self, format: str, *args: Any) -> None:
        return  # the mission's output stays readable

    def do_GET(self) -> None:
        url = urlparse(self.path)
        path = url.path
        try:
            if path in ("/", "/index.html"):
                self._send_file(STATIC_DIR / "index.html")
            elif path.startswith("/static/"):
                self._send_file(STATIC_DIR / Path(path).name)
            elif path == "/favicon.ico":
                self.send_response(HTTPStatus.NO_CONTENT)
                self.end_headers()
            elif path == "/api/session":
                self._send_json(self.server.feed.session())
            elif path == "/api/ticks":
                query = parse_qs(url.query)
                after = int(query.get("after", ["0"])[0])
                limit = min(int(query.get("limit", [str(TICKS_PER_REQUEST)])[0]), TICKS_PER_REQUEST)
                lines, done = self.server.feed.read(after=after, limit=max(limit, 1))
                body = '{"done": ' + ("true" if done else "false") + ', "ticks": [' + ",".join(lines) + "]}"
                self._send_bytes(body.encode(), "application/json")
            elif path.startswith("/rerun/") and Path(path).name in RERUN_ASSETS:
                assets = rerun_assets_dir()
                if assets is None:
                    self.send_error(HTTPStatus.NOT_FOUND, "the Rerun web viewer needs the viewer extra")
                    return
                name = Path(path).name
                self._send_file(assets / name, RERUN_ASSETS[name])
            elif path == WORLD_ROUTE and self.server.world_file is not None:
                self._send_file(self.server.world_file, "application/octet-stream")
            else:
                self.send_error(HTTPStatus.NOT_FOUND)
        except ValueError:
            self.send_error(HTTPStatus.BAD_REQUEST, "after and limit must be integers")
        except (BrokenPipeError, ConnectionResetError):
            return  # the page went away mid-answer

    def _send_json(self, data: Any) -> None:
        self._send_bytes(json.dumps(data).encode(), "application/json")

    def _send_file(self, path: Path, content_type: str | None = None) -> None:
        if not path.is_file():
            self.send_error(HTTPStatus.NOT_FOUND)
            return
        kind = content_type or _CONTENT_TYPES.get(path.suffix, "application/octet-stream")
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(path.stat().st_size))
        self.send_header("Cache-Control", "no-cache")
        self.send_header("Content-Security-Policy", CONTENT_SECURITY_POLICY)
        self.end_headers()
        with open(path, "rb") as handle:
            while chunk := handle.read(1 << 20):
                self.wfile.write(chunk)

    def _send_bytes(self, body: bytes, content_type: str) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)


class _PageServer(ThreadingHTTPServer):
    daemon_threads = True
    feed: TickFeed
    world_file: Path | None


class ViewServer:
    """Serves the tree page for one feed on the loopback interface, in a background thread.

    Args:
        feed: what the page shows.
        world_file: a saved ``world.rrd`` to serve at ``/world.rrd`` (replay), or None.
        host: the interface (loopback by default; the page has no authentication).
        port: the port; 0 picks a free one.
    """

    def __init__(
        self, feed: TickFeed, *, world_file: Path | None = None, host: str = "127.0.0.1", port: int = 0
    ):
        self.feed = feed
        self._server = _PageServer((host, port), _Handler)
        self._server.feed = feed
        self._server.world_file = world_file
        self._thread = threading.Thread(
            target=self._server.serve_forever,
            kwargs={"poll_interval": SHUTDOWN_POLL_S},
            name="semexp-view-http",
            daemon=True,
        )
        self._thread.start()

    @property
    def url(self) -> str:
        host, port = self._server.server_address[:2]
        return f"http://{host!s}:{port}/"

    @property
    def origin(self) -> str:
        return self.url.rstrip("/")

    def open_browser(self) -> bool:
        """Open the page in the user's browser, if there is one (False on a machine without)."""
        try:
            return bool(webbrowser.open(self.url))
        except webbrowser.Error:
            return False

    def close(self) -> None:
        """Stop serving (the page's next request fails)."""
        self._server.shutdown()
        self._server.server_close()
        self._thread.join(timeout=5.0)
