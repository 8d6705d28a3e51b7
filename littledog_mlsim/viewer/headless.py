"""Headless Chromium driven over the DevTools protocol, to look at the view as a person would
(the browser tests, ``benchmarks/viewer``). Not used by the view itself.

One browser process, one page; :meth:`Browser.open` navigates (recording every request the page
makes), :meth:`Browser.screenshot` returns the page as an RGB array, :meth:`Browser.evaluate`
runs JavaScript. WebGL is software (SwiftShader), so it works without a GPU or a display.

Offline check: with ``proxy`` every non-loopback request goes to that address instead of the
network (Chromium always sends loopback addresses direct, its implicit bypass rule);
:class:`RecordingProxy` is such an address on this machine that refuses everything and records
what was asked of it.
"""
from __future__ import annotations

import base64
import io
import json
import os
import shutil
import socket
import subprocess
import tempfile
import threading
import time
from typing import Any

import numpy as np

__all__ = ["chromium_path", "Browser", "RecordingProxy", "BrowserError"]

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


class BrowserError(RuntimeError):
    pass


def chromium_path() -> str | None:
    for name in CHROMIUM_NAMES:
        p = shutil.which(name)
        if p:
            return p
    return None


class RecordingProxy:
    """A TCP listener on 127.0.0.1 that records the first line of each connection (an HTTP
    proxy request: ``GET http://host/...`` or ``CONNECT host:443``) and closes it."""

    def __init__(self) -> None:
        self.requests: list[str] = []
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except OSError:
                continue
            with conn:
                conn.settimeout(1.0)
                try:
                    data = conn.recv(4096)
                except OSError:
                    data = b""
                line = data.split(b"\r\n", 1)[0].decode("latin-1", "replace")
                self.requests.append(line or "<connection without a request>")
                try:
                    conn.sendall(b"HTTP/1.1 502 Bad Gateway\r\nContent-Length: 0\r\n"
                                 b"Connection: close\r\n\r\n")
                except OSError:
                    pass

    def close(self) -> None:
        self._stop.set()
        self.thread.join(2.0)
        self.sock.close()


class Browser:
    """Headless Chromium with one page (module doc). Use as a context manager."""

    def __init__(self, width: int = 1280, height: int = 800, proxy: str | None = None,
                 timeout: float = 60.0) -> None:
        from websockets.sync.client import connect

        exe = chromium_path()
        if exe is None:
            raise BrowserError("no chromium on PATH")
        self.tmp = tempfile.mkdtemp(prefix="ldv_chromium_")
        argv = [exe, "--headless=new", "--no-sandbox", "--enable-unsafe-swiftshader",
                "--use-angle=swiftshader", "--remote-debugging-port=0",
                f"--user-data-dir={self.tmp}", f"--window-size={width},{height}",
                "--no-first-run", "--no-default-browser-check", "--disable-extensions",
                "--disable-background-networking", "--disable-component-update",
                "--disable-sync", "--metrics-recording-only", "--mute-audio",
                "--disable-default-apps", "--no-pings", "--disable-domain-reliability",
                "--disable-client-side-phishing-detection"]
        if proxy:
            argv.append(f"--proxy-server={proxy}")   # loopback stays direct (implicit bypass)
        argv.append("about:blank")
        # TMPDIR inside the profile: chromium's own /tmp/org.chromium.Chromium.* directory (its
        # singleton socket), which it leaves behind on SIGTERM, goes with the profile in close()
        self.proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, text=True,
                                     env=dict(os.environ, TMPDIR=self.tmp))
        self.timeout = timeout
        ws_url = None
        end = time.monotonic() + timeout
        assert self.proc.stderr is not None
        while time.monotonic() < end:
            line = self.proc.stderr.readline()
            if not line:
                if self.proc.poll() is not None:
                    break
                continue
            if "DevTools listening on " in line:
                ws_url = line.split("DevTools listening on ", 1)[1].strip()
                break
        if ws_url is None:
            self.close()
            raise BrowserError("chromium did not start (no DevTools address)")
        threading.Thread(target=self._drain, daemon=True).start()
        port = ws_url.split(":")[2].split("/")[0]
        self.browser_ws = connect(ws_url, max_size=None, open_timeout=timeout)
        self._id = 0
        self.events: list[dict[str, Any]] = []
        target = self._call(self.browser_ws, "Target.createTarget", url="about:blank")
        self.page_ws = connect(f"ws://127.0.0.1:{port}/devtools/page/{target['targetId']}",
                               max_size=None, open_timeout=timeout)
        self.send("Page.enable")
        self.send("Network.enable")
        self.send("Emulation.setDeviceMetricsOverride", width=width, height=height,
                  deviceScaleFactor=1, mobile=False)

    def _drain(self) -> None:
        try:
            for _ in self.proc.stderr:      # keep the pipe from filling up
                pass
        except (ValueError, OSError):
            pass

    def _call(self, ws, method: str, **params: Any) -> dict[str, Any]:
        self._id += 1
        mid = self._id
        ws.send(json.dumps({"id": mid, "method": method, "params": params}))
        end = time.monotonic() + self.timeout
        while True:
            left = end - time.monotonic()
            if left <= 0:
                raise BrowserError(f"no answer to {method} within {self.timeout:g} s")
            msg = json.loads(ws.recv(timeout=left))
            if msg.get("id") == mid:
                if "error" in msg:
                    raise BrowserError(f"{method}: {msg['error'].get('message')}")
                return msg.get("result", {})
            if "method" in msg:
                self.events.append(msg)

    def send(self, method: str, **params: Any) -> dict[str, Any]:
        return self._call(self.page_ws, method, **params)

    def requested_urls(self) -> list[str]:
        """Every URL the page asked for since the last :meth:`open`, websockets included
        (DevTools Network events)."""
        out = []
        for e in self.events:
            if e.get("method") == "Network.requestWillBeSent":
                out.append(e["params"]["request"]["url"])
            elif e.get("method") == "Network.webSocketCreated":
                out.append(e["params"]["url"])
        return out

    def open(self, url: str, settle: float = 0.0) -> str | None:
        """Navigate; wait for the load event (up to the timeout) and ``settle`` s more. Returns
        the navigation error text (e.g. net::ERR_PROXY_CONNECTION_FAILED) or None."""
        self.events.clear()
        r = self.send("Page.navigate", url=url)
        if r.get("errorText"):
            return r["errorText"]
        end = time.monotonic() + self.timeout
        while not any(e.get("method") == "Page.loadEventFired" for e in self.events):
            if time.monotonic() > end:
                raise BrowserError(f"{url} did not load within {self.timeout:g} s")
            self.send("Runtime.evaluate", expression="1")   # collects events meanwhile
            time.sleep(0.05)
        time.sleep(settle)
        return None

    def evaluate(self, expression: str) -> Any:
        r = self.send("Runtime.evaluate", expression=expression, returnByValue=True,
                      awaitPromise=True)
        if "exceptionDetails" in r:
            raise BrowserError(f"JavaScript error: {r['exceptionDetails'].get('text')}")
        return r.get("result", {}).get("value")

    def wait_for(self, expression: str, timeout: float = 30.0) -> Any:
        """Poll a JavaScript expression until it is truthy; its value."""
        end = time.monotonic() + timeout
        while True:
            v = self.evaluate(expression)
            if v:
                return v
            if time.monotonic() > end:
                raise BrowserError(f"{expression!r} still false after {timeout:g} s")
            time.sleep(0.1)

    def screenshot(self) -> np.ndarray:
        """The page as an (H, W, 3) uint8 array."""
        from PIL import Image

        r = self.send("Page.captureScreenshot", format="png")
        img = Image.open(io.BytesIO(base64.b64decode(r["data"]))).convert("RGB")
        return np.asarray(img)

    def close(self) -> None:
        for ws in (getattr(self, "page_ws", None), getattr(self, "browser_ws", None)):
            try:
                if ws is not None:
                    ws.close()
            except Exception:
                pass
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        shutil.rmtree(self.tmp, ignore_errors=True)

    def __enter__(self) -> "Browser":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
