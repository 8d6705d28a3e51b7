"""The browser view's targets: no slower simulator, >= 30 robot states per second shown, < 3 s
start-up.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/viewer/bench_viewer.py \
        --model bags/default_lr --bag bags/default/F_15 --duration 20 --rounds 2 \
        --out benchmarks/viewer

1. sim_node's step time at 100 Hz, alone and watched. sim_node runs as a process in timer
   mode (100 Hz steady-clock timer, no commands: it holds the stand command; ``latency_log``
   on). Scenarios alternate ``--rounds`` times: ``alone``; ``view`` = the same plus
   ``littledog-mlsim view --live`` (its own process, default best-effort subscription, 50 fps,
   no browser); ``view + browser`` = also a headless Chromium page rendering the view with
   software WebGL (SwiftShader: the rendering runs on the CPU cores the simulator shares).
   Step time = the node's own step start to
   last publish (``latency_log``), over ``--duration`` s after a 3 s warm-up; p50/p99/max and the
   published rate.
2. Robot states per second in the browser (``view + browser``, after the page's warm-up:
   SwiftShader compiles its shaders first, tens of seconds under load): JavaScript counts
   (a) DOM mutations of the status line, which the view rewrites with every robot frame it
   draws (= frames received and applied by the page), and (b) animation frames
   (requestAnimationFrame) in which the status differed from the previous one (= frames of new
   robot state rendered), plus all animation frames; also the view's own count of frames sent.
   In the ``view`` scenario a Python websocket client speaks viser's protocol like the page
   (subprotocol, zstd + msgpack windows) and counts the distinct robot frames it receives per
   second: what a page gets, independent of how fast the machine can render it.
3. Start-up: wall time from launching ``littledog-mlsim view`` to the page being served (HTTP
   200 on /) and to its "ready" line, for ``--live`` (one robot) and for a bag replay (and for
   the replay of ``--startup-replay``, e.g. with learned simulators whose rollouts are computed
   after the page is served); 3 runs each, median reported.

The machine is shared: the load average is recorded beside every number.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request
from typing import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from littledog_mlsim.viewer.headless import Browser  # noqa: E402

PY = sys.executable
COUNTER_JS = """
(() => {
  const el = document.getElementById('ldv-status');
  window.__ldvReset = () => {
    window.__ldv = {mut: 0, raf: 0, rafNew: 0, last: '', t0: performance.now()};
    return true;
  };
  window.__ldvReset();
  new MutationObserver(() => { window.__ldv.mut++; })
    .observe(el, {childList: true, characterData: true, subtree: true});
  // the status element is replaced when viser re-renders the HTML: observe its parent too
  new MutationObserver(() => { window.__ldv.mut++; })
    .observe(el.parentElement.parentElement, {childList: true, subtree: true, characterData: true});
  const tick = () => {
    const s = (document.getElementById('ldv-status') || {}).textContent;
    window.__ldv.raf++;
    if (s !== window.__ldv.last) { window.__ldv.rafNew++; window.__ldv.last = s; }
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
  return true;
})()
"""
READ_JS = ("JSON.stringify({mut: window.__ldv.mut, raf: window.__ldv.raf, rafNew: "
           "window.__ldv.rafNew, t: performance.now() - window.__ldv.t0, status: "
           "(document.getElementById('ldv-status') || {}).textContent})")


def wire_frames(url: str, seconds: float) -> dict:
    """Robot frames a viser client receives: connect to the view's websocket as the page does
    (subprotocol viser-v<version>), decode its windows (zstd msgpack, module doc of viser's
    infra) and count distinct "frame N" status updates per second (each drawn frame sends
    one, with the robots' link poses in the same window)."""
    import msgspec
    import viser
    import zstandard
    from websockets.sync.client import connect

    dec = zstandard.ZstdDecompressor()
    frames: set[int] = set()
    windows = 0
    ws = connect(url.replace("http://", "ws://"), subprotocols=[f"viser-v{viser.__version__}"],
                 max_size=None)
    t0 = time.perf_counter()
    try:
        while time.perf_counter() - t0 < seconds:
            try:
                data = ws.recv(timeout=1.0)
            except TimeoutError:
                continue
            if not isinstance(data, bytes) or len(data) < 16:
                continue
            n_in = int.from_bytes(data[:8], "little")
            n_c = int.from_bytes(data[8:16], "little")
            inner = msgspec.msgpack.decode(dec.decompress(data[16:16 + n_c],
                                                          max_output_size=n_in))
            windows += 1
            for m in inner.get("messages", ()):
                text = json.dumps(m, default=str)
                for k in re.findall(r"frame (\d+)", text):
                    frames.add(int(k))
        secs = time.perf_counter() - t0
    finally:
        ws.close()
    return {"client_frames_per_s": len(frames) / secs, "client_windows_per_s": windows / secs}


def load() -> float:
    return os.getloadavg()[0]


def env(domain: int) -> dict[str, str]:
    return dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1", PYTHONUNBUFFERED="1")


def stop(p: subprocess.Popen) -> None:
    if p.poll() is None:
        p.send_signal(signal.SIGINT)
        try:
            p.wait(15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def wait_http(url: str, timeout: float = 60.0) -> float:
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < timeout:
        try:
            with urllib.request.urlopen(url, timeout=1) as r:
                if r.status == 200:
                    return time.perf_counter()
        except OSError:
            time.sleep(0.02)
    raise RuntimeError(f"{url} not served within {timeout} s")


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def sim_run(model: str, domain: int, duration: float, watched: bool, browser_on: bool = True,
            size: tuple[int, int] = (800, 500), client: bool = True) -> dict:
    tmp = Path(tempfile.mkdtemp(prefix="bench_viewer_"))
    log = tmp / "latency.csv"
    sim = subprocess.Popen([PY, "-m", "littledog_mlsim.nodes.sim_node", "--ros-args", "-p",
                            f"model_path:={model}", "-p", f"latency_log:={log}", "-p",
                            "stats_period:=0.0"], env=env(domain), stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
    view = browser = None
    out: dict = {"scenario": ("view + browser" if browser_on else "view" if client
                              else "view, no page") if watched else "alone"}
    loads = [load()]
    try:
        if watched:
            port = free_port()
            view = subprocess.Popen([PY, "-m", "littledog_mlsim.cli", "view", "--live",
                                     f"sim={domain}", "--port", str(port), "--no-plots"],
                                    env=env(domain), stdout=subprocess.PIPE,
                                    stderr=subprocess.STDOUT, text=True)
            url = f"http://127.0.0.1:{port}"
            wait_http(url)
        wire: dict = {}
        if watched and not browser_on:
            time.sleep(3.0 + 5.0)
        elif watched:
            browser = Browser(*size, timeout=120)
            browser.open(url)
            browser.wait_for("((document.getElementById('ldv-status')||{}).textContent||'')"
                             ".includes('frame')", timeout=120)
            browser.evaluate(COUNTER_JS)
            # warm-up: SwiftShader compiles the shaders first (tens of seconds under load);
            # measure once the page draws at least 20 animation frames per second (or after
            # 90 s, whatever it does then)
            end = time.monotonic() + 90
            while time.monotonic() < end:
                browser.evaluate("window.__ldvReset()")
                time.sleep(2.0)
                r = json.loads(browser.evaluate(READ_JS))
                if r["raf"] / (r["t"] / 1000) >= 20:
                    break
            out["warmup_s"] = 90 - (end - time.monotonic())
            browser.evaluate("window.__ldvReset()")
            f0 = _frame_no(browser.evaluate(READ_JS))
        else:
            time.sleep(3.0 + 8.0)                      # start-up and warm-up
        t_start = time.time_ns()
        if watched and not browser_on and client:   # a websocket client stands in for the page
            wire = wire_frames(url, duration)
        else:
            time.sleep(duration)
        t_end = time.time_ns()
        out.update(wire)
        loads.append(load())
        if browser is not None:
            r = json.loads(browser.evaluate(READ_JS))
            secs = r["t"] / 1000.0
            out.update(page_mutations_per_s=r["mut"] / secs, page_new_state_frames_per_s=
                       r["rafNew"] / secs, page_animation_frames_per_s=r["raf"] / secs,
                       view_frames_sent_per_s=(_frame_no(json.dumps(r)) - f0) / secs,
                       page_seconds=secs)
    finally:
        if browser is not None:
            browser.close()
        if view is not None:
            stop(view)
        stop(sim)
    rows = np.loadtxt(log, delimiter=",", skiprows=1, dtype=np.int64, ndmin=2)
    win = rows[(rows[:, 1] >= t_start) & (rows[:, 1] < t_end)]
    step_ms = (win[:, 2] - win[:, 1]) / 1e6
    out.update(steps=int(len(win)), published_hz=len(win) / ((t_end - t_start) / 1e9),
               step_ms_p50=float(np.percentile(step_ms, 50)),
               step_ms_p99=float(np.percentile(step_ms, 99)), step_ms_max=float(step_ms.max()),
               load_min=min(loads), load_max=max(loads))
    return out


def _frame_no(text: str) -> int:
    m = re.search(r"frame (\d+)", text)
    return int(m.group(1)) if m else 0


def startup(argv: list[str], domain: int) -> dict:
    port = free_port()
    t0 = time.perf_counter()
    p = subprocess.Popen([PY, "-m", "littledog_mlsim.cli", "view", *argv, "--port", str(port)],
                         env=env(domain), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True)
    try:
        served = wait_http(f"http://127.0.0.1:{port}") - t0
        ready = None
        assert p.stdout is not None
        for line in p.stdout:
            if "ready in" in line:
                ready = time.perf_counter() - t0
                break
    finally:
        stop(p)
    return {"served_s": served, "ready_line_s": ready, "load": load()}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", required=True)
    ap.add_argument("--bag", required=True)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--domain", type=int, default=175)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/viewer"))
    ap.add_argument("--scenarios", default="alone,view,view+browser",
                    help="comma-separated among alone, view-no-page, view, view+browser")
    ap.add_argument("--no-startup", action="store_true", help="skip the start-up runs")
    ap.add_argument("--name", default="result", help="output file stem (default result)")
    ap.add_argument("--startup-replay", default=None, metavar="ARGS",
                    help="also time the start-up of this replay (view arguments in one string, "
                         "e.g. '--data D --move F_15 --model M --projection none,alpha')")
    a = ap.parse_args()
    kinds = {"alone": (False, False, False), "view-no-page": (True, False, False),
             "view": (True, False, True), "view+browser": (True, True, True)}
    runs = []
    for r in range(a.rounds):
        for name in a.scenarios.split(","):
            watched, browser_on, client = kinds[name.strip()]
            res = sim_run(a.model, a.domain, a.duration, watched, browser_on, client=client)
            res["round"] = r
            print(json.dumps(res), flush=True)
            runs.append(res)
    starts = {} if a.no_startup else {
        "live": [startup(["--live", f"sim={a.domain}"], a.domain) for _ in range(3)],
        "bag": [startup(["--bag", a.bag], a.domain) for _ in range(3)]}
    if a.startup_replay and not a.no_startup:
        starts["replay " + a.startup_replay] = [startup(a.startup_replay.split(), a.domain)
                                               for _ in range(3)]
    print(json.dumps(starts), flush=True)
    return save(a.out, a.name, runs, starts, report)


def save(out: Path, name: str, runs: list, starts: object, render: Callable[[dict], str]) -> int:
    """Write ``out/name``.json (command, date, runs, start-ups) and ``.md`` (``render(doc)``)."""
    doc = {"command": "OPENBLAS_NUM_THREADS=1 .venv/bin/python " + " ".join(
        [str(Path(sys.argv[0]).resolve().relative_to(ROOT))] + sys.argv[1:]),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "runs": runs,
        "startup": starts}
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{name}.json").write_text(json.dumps(doc, indent=1) + "\n")
    (out / f"{name}.md").write_text(render(doc))
    print(render(doc))
    return 0


def report(doc: dict) -> str:
    L = ["# Viewer benchmark result", "", f"{doc['date']}, made by:", "",
         f"    {doc['command']}", "",
         "## sim_node step time at 100 Hz, alone vs watched (view + Chromium page)", "",
         "| round | scenario | published Hz | step p50 / p99 / max ms | page: status mutations/s "
         "| page: new-state animation frames/s | page: animation frames/s | view frames sent/s "
         "| load avg |", "|---|---|---|---|---|---|---|---|---|"]
    for r in doc["runs"]:
        pg = (f"{r['page_mutations_per_s']:.1f} | {r['page_new_state_frames_per_s']:.1f} | "
              f"{r['page_animation_frames_per_s']:.1f} | {r['view_frames_sent_per_s']:.1f}"
              if "page_mutations_per_s" in r else "- | - | - | -")
        if "client_frames_per_s" in r:
            pg = f"(websocket client) {r['client_frames_per_s']:.1f} | - | - | -"
        L.append(f"| {r['round']} | {r['scenario']} | {r['published_hz']:.2f} | "
                 f"{r['step_ms_p50']:.3f} / {r['step_ms_p99']:.3f} / {r['step_ms_max']:.1f} | "
                 f"{pg} | {r['load_min']:.1f}-{r['load_max']:.1f} |")
    warm = [f"{r['warmup_s']:.0f} s" for r in doc["runs"] if "warmup_s" in r]
    if warm:
        L += ["", "Page warm-up (shader compilation) before measuring: " + ", ".join(warm) + "."]
    if not doc["startup"]:
        return "\n".join(L) + "\n"
    L += ["", "## Start-up (launch to page served; launch to the \"ready\" line)", "",
          "| mode | served s (3 runs) | median | ready line s (median) | load avg |",
          "|---|---|---|---|---|"]
    for mode, rs in doc["startup"].items():
        L.append(f"| {mode} | {startup_cells(rs)} |")
    return "\n".join(L) + "\n"


def startup_cells(rs: list[dict]) -> str:
    """Table cells of start-up runs: served times, their median, the ready line's median and
    the load range."""
    served = [x["served_s"] for x in rs]
    ready = [x["ready_line_s"] for x in rs if x["ready_line_s"] is not None]
    return (f"{', '.join(f'{v:.2f}' for v in served)} | {np.median(served):.2f} | "
            f"{np.median(ready):.2f} | "
            f"{min(x['load'] for x in rs):.1f}-{max(x['load'] for x in rs):.1f}")


if __name__ == "__main__":
    sys.exit(main())
