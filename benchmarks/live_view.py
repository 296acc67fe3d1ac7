"""Benchmark of the live view (``motionlib live``): the page's frame rate and the loop's speed while serving.

Run: ``python benchmarks/live_view.py LIBRARY [--motions N] [--width W --height H]``

LIBRARY needs motions between two of its scene's named points, e.g. ``motions: [{starts:
[target-center], targets: {points: [pickup-a]}}, {starts: [pickup-a], targets: {points:
[target-center]}}]`` on ``obstacles/log-loading.yaml`` (as tests/integration/test_live.py builds).
The server runs here (:func:`motionlib.viz.live.live`, defaults: M6, passive operator, 30 updates/s);
Debian's headless Chromium (software WebGL: no GPU) shows the page. The named points are
commanded in turn, ``--motions`` times. Per motion the table gives:

* ``page frames/s``: ``requestAnimationFrame`` callbacks per second in the page while the crane moves
  (counted over 2 s of the motion): how often the page redraws;
* ``updates/s``: distinct update numbers the page's status line showed per second in that window
  (the server sends ``update_hz``; the page shows as many as it redraws);
* ``idle frames/s``: the same count before the first motion, the crane at rest;
* ``loop x real``: :attr:`LiveState.compute_factor <motionlib.viz.live.LiveState.compute_factor>`,
  simulated time per wall time the loop and its page updates took (waits left out);
* ``paced x``: :attr:`LiveState.paced_factor <motionlib.viz.live.LiveState.paced_factor>`,
  simulated time per wall time (1: real time).
"""

from __future__ import annotations

import argparse
import time

from playwright.sync_api import sync_playwright

from motionlib.viz.live import LiveOptions, LiveStatus, live

CHROMIUM = "/usr/bin/chromium"
RATES_JS = """(seconds) => new Promise(resolve => {
  let frames = 0; const updates = new Set(); const t0 = performance.now();
  function frame() {
    frames++;
    const m = document.body.innerText.match(/update (\\d+)/); if (m) updates.add(m[1]);
    const dt = performance.now() - t0;
    if (dt < 1000 * seconds) requestAnimationFrame(frame);
    else resolve([1000 * frames / dt, 1000 * updates.size / dt]);
  }
  requestAnimationFrame(frame);
})"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("library")
    parser.add_argument("--motions", type=int, default=4)
    parser.add_argument("--width", type=int, default=900)
    parser.add_argument("--height", type=int, default=600)
    args = parser.parse_args()
    server = live(args.library, LiveOptions(port=0))
    names = list(server.scene.points)
    rows = []
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox", "--disable-gpu"])
            page = browser.new_page(viewport={"width": args.width, "height": args.height})
            page.goto(server.url)
            page.wait_for_function("document.body.innerText.includes('update 0')", timeout=60_000)
            page.wait_for_timeout(1000)
            idle = page.evaluate(RATES_JS, 2.0)[0]
            for k in range(args.motions):
                here = server.state.q  # the next named point the library has a motion to from here
                name = next((n for n in names if server.library.select_checked(server.scene.points[n], here).ok), None)
                if name is None:
                    raise SystemExit("no named point has a library motion from the crane's configuration")
                assert server.go_to_point(name)
                while server.state.status is not LiveStatus.RUNNING:
                    time.sleep(0.02)
                frames, updates = page.evaluate(RATES_JS, 2.0)
                while server.state.status is LiveStatus.RUNNING:
                    time.sleep(0.05)
                s = server.state
                rows.append((k + 1, name, frames, updates, idle, s.compute_factor, s.paced_factor))
            browser.close()
    finally:
        server.stop()
    print(f"live view of {args.library}, page {args.width}x{args.height}, headless Chromium (software WebGL)")
    print(
        f"{'motion':>6} {'to':>16} {'page frames/s':>13} {'updates/s':>9} {'idle frames/s':>13} "
        f"{'loop x real':>11} {'paced x':>7}"
    )
    for k, name, frames, updates, idle_fps, compute, paced in rows:
        print(f"{k:>6} {name:>16} {frames:>13.1f} {updates:>9.1f} {idle_fps:>13.1f} {compute:>11.1f} {paced:>7.3f}")


if __name__ == "__main__":
    main()
