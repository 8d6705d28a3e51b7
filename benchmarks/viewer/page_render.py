"""What limits the headless Chromium page's frame rate: the view, or rasterising pixels?

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/viewer/page_render.py --out benchmarks/viewer

No ROS: this process draws one robot (``ViewerApp.draw``, a moving pose and swinging legs) at
40 frames per second, and headless Chromium (``viewer.headless.Browser``; WebGL on the CPU
with SwiftShader where there is no GPU) shows the page. Variants, each in a fresh browser and
server, in turn:

- ``800x500``: the window of ``bench_viewer.py``;
- ``400x250``: a quarter of the pixels, same scene;
- ``800x500, no grid``: the ground grid (a shader plane under the whole view) replaced by an
  empty node.

After ``--warmup`` s the page's counters (``bench_viewer.COUNTER_JS``: status-line mutations =
robot frames applied, animation frames, animation frames with a new state) run for
``--seconds`` s. If the rate rises as the pixels fall, the renderer, not the view, is the limit.
The load average is recorded beside every number.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT))

from bench_viewer import COUNTER_JS, READ_JS  # noqa: E402
from littledog_mlsim.layout import HOME_POSE  # noqa: E402
from littledog_mlsim.viewer.headless import Browser  # noqa: E402
from littledog_mlsim.viewer.scene import Frame, ViewerApp  # noqa: E402

VARIANTS = {"800x500": (800, 500, True), "400x250": (400, 250, True),
            "800x500, no grid": (800, 500, False)}


def run(name: str, warmup: float, seconds: float) -> dict:
    w, h, grid = VARIANTS[name]
    app = ViewerApp(["robot"], port=0, plots=False)
    if not grid:
        app.server.scene.add_frame("/ground", show_axes=False)     # replaces the grid
    stop = threading.Event()

    def feed() -> None:
        k = 0
        while not stop.wait(0.025):
            k += 1
            q = HOME_POSE + 0.2 * np.sin(k / 10.0)
            app.draw([Frame(k * 0.025, np.array([(0.01 * k) % 1.0, 0.0, 0.146]),
                            np.array([0.0, 0.0, 0.0, 1.0]), q, None)])

    threading.Thread(target=feed, daemon=True).start()
    browser = Browser(w, h, timeout=120)
    loads = [os.getloadavg()[0]]
    try:
        browser.open(app.url.replace("localhost", "127.0.0.1"))
        browser.wait_for("((document.getElementById('ldv-status')||{}).textContent||'')"
                         ".includes('frame')", timeout=120)
        browser.evaluate(COUNTER_JS)
        time.sleep(warmup)
        browser.evaluate("window.__ldvReset()")
        time.sleep(seconds)
        r = json.loads(browser.evaluate(READ_JS))
        loads.append(os.getloadavg()[0])
    finally:
        browser.close()
        stop.set()
        app.stop()
    s = r["t"] / 1000.0
    return {"variant": name, "page_mutations_per_s": r["mut"] / s,
            "page_animation_frames_per_s": r["raf"] / s,
            "page_new_state_frames_per_s": r["rafNew"] / s, "seconds": s,
            "load_min": min(loads), "load_max": max(loads)}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--warmup", type=float, default=15.0)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/viewer"))
    ap.add_argument("--name", default="page_render")
    a = ap.parse_args()
    runs = []
    for r in range(a.rounds):
        for name in VARIANTS:
            res = run(name, a.warmup, a.seconds)
            res["round"] = r
            print(json.dumps(res), flush=True)
            runs.append(res)
    doc = {"command": "OPENBLAS_NUM_THREADS=1 .venv/bin/python " + " ".join(
        [str(Path(sys.argv[0]).resolve().relative_to(ROOT))] + sys.argv[1:]),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "runs": runs}
    L = ["# Headless Chromium page: frames per second by window size", "",
         f"{doc['date']}, made by:", "", f"    {doc['command']}", "",
         "| round | variant | robot frames applied/s | animation frames/s | load avg |",
         "|---|---|---|---|---|"]
    L += [f"| {x['round']} | {x['variant']} | {x['page_mutations_per_s']:.1f} | "
          f"{x['page_animation_frames_per_s']:.1f} | {x['load_min']:.1f}-{x['load_max']:.1f} |"
          for x in runs]
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / f"{a.name}.json").write_text(json.dumps(doc, indent=1) + "\n")
    (a.out / f"{a.name}.md").write_text("\n".join(L) + "\n")
    print("\n".join(L))
    return 0


if __name__ == "__main__":
    sys.exit(main())
