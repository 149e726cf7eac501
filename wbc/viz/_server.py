"""meshcat server bound to 127.0.0.1 on every port (internal; run as ``python -m wbc.viz._server``).

meshcat 0.3.2's ``ZMQWebSocketBridge`` binds its zmq socket to its ``host`` (127.0.0.1) but calls tornado's
``Application.listen(port)`` without an address, so the web/websocket server listens on all interfaces
(``0.0.0.0`` and ``[::]``). This bridge passes ``address=host`` to ``listen``. It prints the same two lines
as ``meshcat-server`` (``zmq_url=...`` then ``web_url=...``), which :func:`start` reads.

Its page (``/static/``) is meshcat's viewer plus two scripts shared with the HTML recordings: the camera follows
the ``/Cameras/target`` node (the live viewer moves it with the robot's base), and a legend lists the overlays
present under ``/meshcat/overlays`` with their colours. meshcat's other static files are served as before.

The server dies with the process that started it: :func:`start` gives it the parent's pid and a pipe on its stdin
that only the parent holds; a watchdog thread in the server exits the process when the pipe reaches end of file or
the parent pid changes (the parent exited, was killed by SIGTERM, SIGINT or SIGKILL). A malformed message on the
zmq socket (undecodable command, wrong frame count, anything meshcat's handler raises on) is answered with an
``error: ...`` reply, logged on the server's stderr and dropped; the server goes on serving.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time

HOST = "127.0.0.1"


PAGE = """<!DOCTYPE html>
<html>
<head><meta charset="utf-8"><title>wbc live (meshcat)</title>
<style>body { margin: 0; } #meshcat-pane { width: 100vw; height: 100vh; overflow: hidden; }</style>
</head>
<body>
<div id="meshcat-pane"></div>
<script src="main.min.js"></script>
<script>
%(follow)s
%(legend)s
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
try {
  viewer.connect();
} catch (e) {
  console.info("Not connected to the meshcat websocket server: ", e);
}
wbcFollow(viewer);
wbcLiveLegend(viewer);
</script>
</body>
</html>
"""


def _bridge_class():
    import tornado.web
    from meshcat.servers import zmqserver

    from wbc.viz._scene import FOLLOW_JS, LIVE_LEGEND_JS

    page = PAGE % {"follow": FOLLOW_JS, "legend": LIVE_LEGEND_JS}

    class PageHandler(tornado.web.RequestHandler):
        def get(self):
            self.set_header("Content-Type", "text/html; charset=utf-8")
            self.set_header("Cache-Control", "no-store, no-cache, must-revalidate, max-age=0")
            self.write(page)

    class LocalBridge(zmqserver.ZMQWebSocketBridge):
        dropped = 0  # malformed messages answered with an error and dropped

        def handle_zmq(self, frames):
            try:
                frames[0].decode("utf-8")
                super().handle_zmq(frames)
            except Exception as exc:  # noqa: BLE001 - a bad message from any local process must not stop the server
                self.dropped += 1
                head = bytes(frames[0][:40]) if frames else b""
                print(f"wbc live server: dropped a malformed message ({len(frames)} frames, starts {head!r}): "
                      f"{type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
                try:  # REP socket: a reply is due, or every later message fails
                    self.zmq_socket.send(f"error: malformed message dropped ({type(exc).__name__})".encode())
                except Exception:  # noqa: BLE001 - the reply was already sent by meshcat's handler
                    pass

        def make_app(self):
            # meshcat 0.3.2's routes, with wbc's page in front of its index.html
            app = tornado.web.Application([
                (r"/static/(?:index\.html)?", PageHandler),
                (r"/static/(.*)", zmqserver.StaticFileHandlerNoCache,
                 {"path": zmqserver.VIEWER_ROOT, "default_filename": zmqserver.VIEWER_HTML}),
                (r"/", zmqserver.WebSocketHandler, {"bridge": self}),
            ])
            listen = app.listen
            app.listen = lambda port, **kw: listen(port, address=self.host, **kw)
            return app

    return LocalBridge


def start(timeout_lines: int = 50, log=None) -> tuple[subprocess.Popen, str, str]:
    """Start the server as a subprocess; returns ``(process, zmq_url, web_url)``. The server exits when this
    process does (module docstring); keep the returned ``Popen`` (it holds the server's stdin pipe).

    Args:
        timeout_lines: lines read from the server before giving up.
        log: file path for the server's stderr (dropped messages, websocket connections); None discards it.

    Raises:
        RuntimeError: the server exited before printing its URLs.
    """
    stderr = subprocess.DEVNULL if log is None else open(log, "ab")  # noqa: SIM115 - handed to the child
    try:
        proc = subprocess.Popen([sys.executable, "-u", "-m", "wbc.viz._server", str(os.getpid())],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=stderr, env=dict(os.environ),
                                start_new_session=True)
    finally:
        if log is not None:
            stderr.close()
    urls: dict[str, str] = {}
    for _ in range(timeout_lines):
        line = proc.stdout.readline().decode("utf-8", "replace").strip()
        if not line and proc.poll() is not None:
            break
        key, _, value = line.partition("=")
        if key in ("zmq_url", "web_url"):
            urls[key] = value
        if len(urls) == 2:
            return proc, urls["zmq_url"], urls["web_url"]
    proc.kill()
    proc.wait()
    raise RuntimeError(f"the meshcat server exited before printing its URLs (exit code {proc.poll()})")


def _watch_parent(parent: int, period: float = 0.2) -> None:
    """Exit this process when the parent is gone: end of file on stdin (a pipe only the parent holds) or a
    parent pid that changed (re-parented after the parent's death). Runs in a daemon thread."""
    import select

    stdin = sys.stdin.buffer if sys.stdin is not None else None
    while True:
        if os.getppid() != parent:
            os._exit(0)
        if stdin is not None:
            try:
                ready, _, _ = select.select([stdin], [], [], period)
                if ready and not os.read(stdin.fileno(), 4096):
                    os._exit(0)  # EOF: the parent closed its end or died
            except (OSError, ValueError):
                stdin = None
        else:
            time.sleep(period)


def main() -> None:
    if len(sys.argv) > 1:  # started by start(): die with the parent
        threading.Thread(target=_watch_parent, args=(int(sys.argv[1]),), name="wbc-parent-watchdog",
                         daemon=True).start()
    bridge = _bridge_class()(host=HOST)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
