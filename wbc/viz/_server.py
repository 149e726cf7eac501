"""meshcat server bound to 127.0.0.1 on every port (internal; run as ``python -m wbc.viz._server``).

meshcat 0.3.2's ``ZMQWebSocketBridge`` binds its zmq socket to its ``host`` (127.0.0.1) but calls tornado's
``Application.listen(port)`` without an address, so the web/websocket server listens on all interfaces
(``0.0.0.0`` and ``[::]``). This bridge passes ``address=host`` to ``listen``. It prints the same two lines
as ``meshcat-server`` (``zmq_url=...`` then ``web_url=...``), which :func:`start` reads.

Its page (``/static/``) is meshcat's viewer plus two scripts shared with the HTML recordings: the camera follows
the ``/Cameras/target`` node (the live viewer moves it with the robot's base), and a legend lists the overlays
present under ``/meshcat/overlays`` with their colours. meshcat's other static files are served as before.
"""

from __future__ import annotations

import os
import subprocess
import sys

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


def start(timeout_lines: int = 50) -> tuple[subprocess.Popen, str, str]:
    """Start the server as a subprocess; returns ``(process, zmq_url, web_url)``.

    Raises:
        RuntimeError: the server exited before printing its URLs.
    """
    proc = subprocess.Popen([sys.executable, "-u", "-m", "wbc.viz._server"], stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, env=dict(os.environ), start_new_session=True)
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


def main() -> None:
    bridge = _bridge_class()(host=HOST)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass


if __name__ == "__main__":
    main()
