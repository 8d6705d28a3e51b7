"""The view as a person sees it: headless Chromium loads the page and takes screenshots.

Two fake simulators (this process publishes /littledog/joint_states and /littledog/odom in two
ROS domains from this helper's range) feed a live view (``viewer.live`` + ``viewer.scene``) on
an ephemeral port. Checks:

- the robot is drawn: the 3-D area differs from the empty scene once a state arrives, and
  moving the robot changes it again;
- two simulators appear as two robots: two separate blobs of leg-blue pixels;
- the page loads with the network unreachable: Chromium (fresh profile, empty cache) runs with
  every non-loopback request sent to a refusing proxy on 127.0.0.1 that records them; a probe
  of an outside address proves the routing (the proxy sees it, the navigation fails), and the
  view's load, which draws the robots, asks the proxy for nothing and requests only loopback
  URLs (DevTools' list of the page's requests; viser's websocket runs in a web worker, whose
  connections DevTools lists elsewhere: any outside one would have reached the proxy).

Skipped, with the reason, where Chromium is missing (``make test`` installs Debian's package
when it runs as root with apt-get).
"""
from __future__ import annotations

import os
import threading
import time
from urllib.parse import urlparse

import numpy as np
import pytest

from littledog_mlsim.viewer.headless import chromium_path

pytestmark = pytest.mark.skipif(
    chromium_path() is None,
    reason="no chromium on PATH: the browser tests need Debian's chromium package (make test "
           "installs it when run as root with apt-get; else: apt-get install chromium)")

DOMAINS = (170 + 2 * (os.getpid() % 5), 171 + 2 * (os.getpid() % 5))   # this helper's range
W, H = 800, 500


class FakeSim:
    """Publishes the contract's joint states and odometry of a settable pose at 25 Hz."""

    def __init__(self, domain: int) -> None:
        import rclpy
        from nav_msgs.msg import Odometry
        from rclpy.context import Context
        from rclpy.node import Node
        from rclpy.signals import SignalHandlerOptions
        from sensor_msgs.msg import JointState

        from littledog_mlsim.layout import HOME_POSE, TOPIC_JOINT_STATES, TOPIC_ODOM
        from littledog_mlsim.nodes.simulator import SIM_QOS

        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain,
                   signal_handler_options=SignalHandlerOptions.NO)
        self.node = Node(f"fake_sim_{domain}", context=self.context)
        self.pub_js = self.node.create_publisher(JointState, TOPIC_JOINT_STATES, SIM_QOS)
        self.pub_odom = self.node.create_publisher(Odometry, TOPIC_ODOM, SIM_QOS)
        self.xy = None            # None: silent
        self.q = HOME_POSE.copy()
        self.k = 0
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        from littledog_mlsim.nodes.messages import joint_state_msg, odometry_msg

        while not self._stop.wait(0.04):
            if self.xy is None:
                continue
            self.k += 1
            ns = self.k * 10_000_000
            self.pub_js.publish(joint_state_msg(ns, self.q, self.q * 0))
            self.pub_odom.publish(odometry_msg(ns, [self.xy[0], self.xy[1], 0.146],
                                               [0, 0, 0, 1], [0] * 3, [0] * 3))

    def close(self) -> None:
        import rclpy

        self._stop.set()
        self.thread.join(2)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


@pytest.fixture(scope="module")
def setup():
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    from littledog_mlsim.viewer.headless import Browser, RecordingProxy
    from littledog_mlsim.viewer.live import LiveSource, LiveView, SimSpec
    from littledog_mlsim.viewer.scene import ViewerApp

    sims = [FakeSim(d) for d in DOMAINS]
    specs = [SimSpec("a", DOMAINS[0], ""), SimSpec("b", DOMAINS[1], "")]
    app = ViewerApp(["a", "b"], port=0, plots=False)
    source = LiveSource(specs)
    view = LiveView(app, source, rate=30)
    proxy = RecordingProxy()
    browser = Browser(W, H, proxy=f"http://127.0.0.1:{proxy.port}")
    yield {"sims": sims, "app": app, "source": source, "browser": browser, "proxy": proxy}
    browser.close()
    proxy.close()
    view.close()
    source.close()
    app.stop()
    for s in sims:
        s.close()


# Chromium's own background services (sign-in, autofill, time, component updates) also go to
# the proxy; they are the browser's, not the page's, so they are set aside here.
_BROWSER_SERVICES = ("google.com", "googleapis.com", "gvt1.com", "gstatic.com")


def _page_proxy_requests(proxy, since: int) -> list[str]:
    return [r for r in proxy.requests[since:] if r != "<connection without a request>"
            and not any(h in r.split(" ")[1] if " " in r else False for h in _BROWSER_SERVICES)]


STATUS = "(document.getElementById('ldv-status') || {}).textContent || ''"


def _scene(img: np.ndarray) -> np.ndarray:
    """The 3-D area: left of the control panel, below the software-WebGL notice, right of the
    axes gizmo (bottom left)."""
    return img[int(0.25 * H): int(0.88 * H), int(0.1 * W): int(0.62 * W)].astype(int)


def _shot(b, settle: float = 0.6) -> np.ndarray:
    time.sleep(settle)            # a few rendered frames after the state arrived
    return _scene(b.screenshot())


def _blobs(img: np.ndarray) -> list[int]:
    """Sizes of the connected blobs of leg-blue pixels (each robot's legs, dilated)."""
    from scipy import ndimage

    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    blue = (b - r > 50) & (b - g > 30)
    lab, n = ndimage.label(ndimage.binary_dilation(blue, iterations=12))
    return sorted((int((lab == i).sum()) for i in range(1, n + 1) if (lab == i).sum() > 400),
                  reverse=True)


def _wait_blobs(b, n: int, timeout: float = 60.0) -> list[int]:
    """Screenshots until ``n`` robots show (a fresh page needs a moment to set up WebGL; on a
    loaded machine a software-rendered frame can take seconds, and one caught while a robot
    moves can show its legs apart)."""
    end = time.monotonic() + timeout
    while True:
        sizes = _blobs(_shot(b, 0.5))
        if len(sizes) == n or time.monotonic() > end:
            return sizes


def _wait_status(b, pred, timeout: float = 20.0) -> str:
    end = time.monotonic() + timeout
    while True:
        text = b.evaluate(STATUS)
        if pred(text):
            return text
        if time.monotonic() > end:
            raise AssertionError(f"page status still {text!r} after {timeout} s")
        time.sleep(0.1)


def test_offline_method_blocks(setup):
    """The proxy set-up really routes outside addresses away: a probe fails at the proxy."""
    b, proxy = setup["browser"], setup["proxy"]
    err = b.open("http://viewer-offline-probe.example/asset.js")
    assert err is not None and "ERR_" in err, err
    assert any("viewer-offline-probe.example" in r for r in proxy.requests), proxy.requests


def test_robot_drawn_and_moved(setup):
    b, app, sims = setup["browser"], setup["app"], setup["sims"]
    n_proxy = len(setup["proxy"].requests)
    assert b.open(app.url) is None
    _wait_status(b, lambda t: "waiting" in t)
    empty = _shot(b)
    if os.environ.get("VIEWER_TEST_SHOTS"):
        from PIL import Image
        Image.fromarray(b.screenshot()).save(os.environ["VIEWER_TEST_SHOTS"] + "/empty.png")
    assert _blobs(empty) == []
    sims[0].xy = (0.0, 0.0)
    _wait_status(b, lambda t: "frame" in t)
    one = _shot(b)
    changed = np.abs(one - empty).sum(axis=2) > 30
    assert changed.sum() > 2000, f"robot not drawn: {changed.sum()} pixels changed"
    assert len(_blobs(one)) == 1
    sims[0].xy = (0.25, 0.1)
    k = sims[0].k
    _wait_status(b, lambda t: "frame" in t and sims[0].k > k + 5)
    moved = _shot(b)
    diff = np.abs(moved - one).sum(axis=2) > 30
    assert diff.sum() > 1000, f"moving the robot changed only {diff.sum()} pixels"
    # what the page asked for while loading and drawing (checked in test_page_loads_offline)
    setup["first_load"] = {"proxy": _page_proxy_requests(setup["proxy"], n_proxy),
                           "urls": [u for u in b.requested_urls()
                                    if urlparse(u).scheme not in ("data", "blob", "about")]}


def test_two_simulators_two_robots(setup):
    b, sims = setup["browser"], setup["sims"]
    # robot a back to the origin: b is drawn 0.4 m beside it (layout "side"); left where the
    # last test moved it, a stands in front of b in this camera's view and splits its legs
    k = sims[0].k
    sims[0].xy = (0.0, 0.0)
    _wait_status(b, lambda t: sims[0].k > k + 5)
    assert len(_wait_blobs(b, 1)) == 1
    sims[1].xy = (0.0, 0.0)
    _wait_status(b, lambda t: setup["source"].latest()[1] is not None)
    sizes = _wait_blobs(b, 2)
    assert len(sizes) == 2, f"expected two robots, found blobs of {sizes} pixels"
    assert min(sizes) > 0.3 * max(sizes)


def test_page_loads_offline(setup):
    """The first load above was a cold start behind the refusing proxy (fresh profile, empty
    cache) and drew both robots: the page asked the proxy for nothing and DevTools saw only
    loopback requests."""
    first = setup.get("first_load")
    assert first is not None, "test_robot_drawn_and_moved did not load the page"
    assert first["proxy"] == []
    assert first["urls"], "DevTools recorded no request of the page"
    assert {urlparse(u).hostname for u in first["urls"]} <= {"127.0.0.1", "localhost"}, \
        first["urls"]
