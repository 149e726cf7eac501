"""meshcat server bound to 127.0.0.1 on every port (internal; run as ``python -m wbc.viz._server``).

meshcat 0.3.2's ``ZMQWebSocketBridge`` binds its zmq socket to its ``host`` (127.0.0.1) but calls tornado's
``Application.listen(port)`` without an address, so the web/websocket server listens on all interfaces
(``0.0.0.0`` and ``[::]``). This bridge passes ``address=host`` to ``listen``. It prints the same two lines
as ``meshcat-server`` (``zmq_url=...`` then ``web_url=...``), which :func:`start` reads.
"""

from __future__ import annotations

import os
import subprocess
import sys

HOST = "127.0.0.1"


def _bridge_class():
    from meshcat.servers.zmqserver import ZMQWebSocketBridge

    class LocalBridge(ZMQWebSocketBridge):
        def make_app(self):
            app = super().make_app()
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
