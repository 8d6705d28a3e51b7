"""``make run VIEW=1``: ``python -m littledog_mlsim.apps.demo --view``, end to end.

The demo runs as a process on a tiny dataset (two F moves) with an LR model and a shortened
move, the view on an ephemeral port. Checks: the address it prints answers HTTP with the page
while the simulators run, the live view received the whole run, from its first state to its
last, although the run is short (the demo waits until the view has received both simulators'
initial states before its first command), the page then serves the replay to a websocket
client (viser's protocol) with robot frames, and SIGINT stops everything cleanly (exit status
0, no simulator left).
Every wait is on the process's output or a socket, with a timeout.
"""
from __future__ import annotations

import json
import os
import re
import queue
import signal
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[2]
# the demo uses D and D + 1; LITTLEDOG_TEST_DOMAIN_ID picks D (as in test/nodes/test_nodes.py)
DOMAIN = int(os.environ.get("LITTLEDOG_TEST_DOMAIN_ID") or 210 + 2 * (os.getpid() % 5))
TIMEOUT = 60.0
ADDRESS = re.compile(r"view: open (http://\S+) to watch")
REPLAY = re.compile(r"view: replay of the run at (http://\S+)")
RECEIVED = re.compile(r"view: received (\d+) states of both simulators, t = ([0-9.]+) to "
                      r"([0-9.]+) s")
STEPS = 40          # 0.4 s of simulated time: over in a fraction of a second of wall time


class Lines:
    """The process's stdout, read by a thread into a queue; :meth:`wait_for` waits on it with
    a deadline (no fixed sleeps, no blocking read past the deadline)."""

    def __init__(self, proc: subprocess.Popen) -> None:
        self.proc, self.seen = proc, []
        self.q: queue.Queue[str | None] = queue.Queue()
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.q.put(line)
        self.q.put(None)

    def wait_for(self, pattern: re.Pattern, timeout: float = TIMEOUT) -> re.Match:
        end = time.monotonic() + timeout
        while True:
            try:
                line = self.q.get(timeout=max(0.0, end - time.monotonic()))
            except queue.Empty:
                line = None
            if line is None:                 # timed out, or the process ended
                raise AssertionError(f"no line matching {pattern.pattern!r} within {timeout} s; "
                                     f"exit {self.proc.poll()}; output:\n{''.join(self.seen)}")
            self.seen.append(line)
            m = pattern.search(line)
            if m:
                return m

    def rest(self, timeout: float = 10.0) -> str:
        """Whatever the process still prints until it closes its output."""
        self.thread.join(timeout)
        while not self.q.empty():
            line = self.q.get()
            if line is not None:
                self.seen.append(line)
        return "".join(self.seen)


def children(pid: int) -> set[int]:
    out = set()
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if int((d / "stat").read_text().rsplit(")", 1)[1].split()[1]) == pid:
                    out.add(int(d.name))
            except (OSError, IndexError, ValueError):
                continue
    return out


def get_page(url: str) -> str:
    with urllib.request.urlopen(url, timeout=10) as r:
        assert r.status == 200
        return r.read().decode("utf-8", "replace")


def robot_frames(url: str, timeout: float = 20.0) -> int:
    """Connect to the page's websocket as the browser does (subprotocol ``viser-v<version>``,
    zstd-compressed msgpack windows: a little-endian uncompressed length, the compressed
    length, then the data) and return the first ``frame N`` the view's status line shows."""
    import msgspec
    import viser
    import zstandard
    from websockets.sync.client import connect

    dec = zstandard.ZstdDecompressor()
    end = time.monotonic() + timeout
    with connect(url.replace("http://", "ws://"), subprotocols=[f"viser-v{viser.__version__}"],
                 max_size=None, open_timeout=10) as ws:
        while time.monotonic() < end:
            try:
                data = ws.recv(timeout=max(0.1, end - time.monotonic()))
            except TimeoutError:
                break
            if not isinstance(data, bytes) or len(data) < 16:
                continue
            n_in = int.from_bytes(data[:8], "little")
            n_c = int.from_bytes(data[8:16], "little")
            window = msgspec.msgpack.decode(dec.decompress(data[16:16 + n_c],
                                                           max_output_size=n_in))
            m = re.search(r"t = [0-9.]+ s, frame (\d+)", json.dumps(window, default=str))
            if m:
                return int(m.group(1))
    raise AssertionError(f"no robot frame from {url} within {timeout} s")


def test_demo_view_serves_live_then_replay_and_stops_on_sigint(tiny):
    data, model = tiny
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1", OPENBLAS_NUM_THREADS="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "littledog_mlsim.apps.demo", "--data", str(data), "--model",
         str(model), "--steps", str(STEPS), "--projection", "none", "--domain", str(DOMAIN),
         "--view", "--view-port", "0"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    out = Lines(proc)
    try:
        url = out.wait_for(ADDRESS).group(1)
        assert re.fullmatch(r"http://localhost:\d+", url) and not url.endswith(":0")
        page = get_page(url)                  # served while the demo starts the simulators
        assert "<html" in page.lower()
        replay_url = out.wait_for(REPLAY).group(1)
        text = "".join(out.seen)
        assert replay_url == url
        assert f"replayed {STEPS} lockstep steps" in text
        assert "view: has not received state" not in text, "the demo did not wait for the view"
        assert "nothing to replay" not in text, "the live view received no states of the run"
        # the whole run, from the start: the learned simulator's initial state is stamped
        # 0.01 s (measurement 1) and each of the STEPS - 1 commands it gets adds 0.01 s;
        # pybullet_node has every one of those stamps
        got = RECEIVED.search(text)
        assert got, text
        assert (int(got.group(1)), got.group(2), got.group(3)) == (
            STEPS, "0.01", f"{STEPS * 0.01:.2f}"), got.group(0)
        assert not children(proc.pid), "a simulator outlived the demo's report"
        assert "<html" in get_page(url).lower()
        assert robot_frames(url) >= 1         # the replay draws for a connected page
        proc.send_signal(signal.SIGINT)
        rc = proc.wait(20)
        assert rc == 0, f"exit status {rc}:\n{out.rest()}"
        with pytest.raises(OSError):          # the server is gone
            urllib.request.urlopen(url, timeout=2)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


SERVED = re.compile(r"page served at (http://\S+) after")
READY = re.compile(r"LittleDog view \(replay: (.*)\) at (http://\S+) \(ready in")


def test_view_replay_serves_the_page_before_its_rollouts(tiny):
    """``littledog-mlsim view`` replaying a move with two learned simulators and the physics
    baseline: the page answers once the inputs are loaded, before the rollouts are done (the
    "ready" line comes after), then draws the replay; SIGINT ends it with status 0."""
    data, model = tiny
    env = dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1", OPENBLAS_NUM_THREADS="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "littledog_mlsim.cli", "view", "--data", str(data), "--move",
         "F_01", "--model", str(model), "--projection", "none,alpha", "--physics", "nominal",
         "--port", "0"], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    out = Lines(proc)
    try:
        url = out.wait_for(SERVED).group(1)
        assert "<html" in get_page(url).lower()
        m = out.wait_for(READY)
        assert m.group(2) == url
        assert m.group(1) == "measured, lr none, lr alpha 0.5, physics (nominal)"
        assert robot_frames(url) >= 1
        proc.send_signal(signal.SIGINT)
        rc = proc.wait(20)
        assert rc == 0, f"exit status {rc}:\n{out.rest()}"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
