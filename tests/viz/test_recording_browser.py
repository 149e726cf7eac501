"""What a user sees: recordings written by the CLI (walk, balance, physics walk) and the live page of a running walk,
opened in Debian's chromium through Playwright (no browser download). Each test reads the three.js scene: every
overlay is its own node under /meshcat/overlays and in the legend, the robot's feet are on the z = 0 grid, and
the camera's orbit target follows the base. Waits are on page state, with generous limits (busy 2-core CI).

Set WBC_VIZ_SHOTS=<folder> to keep a screenshot of each page.
"""

from __future__ import annotations

import importlib.util
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from wbc.cli import main

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                 "--disable-background-networking", "--disable-component-update", "--no-first-run",
                 # no name lookups at all (the pages are file:, data: and http://127.0.0.1): a DNS socket of a
                 # lingering browser process fails the ROS 2 tests' loopback guard in the same pytest worker
                 "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1"]
WAIT_MS = 300_000  # page-state waits: generous, a loaded machine renders slowly

if not Path(CHROMIUM).exists() or importlib.util.find_spec("playwright") is None:
    pytest.skip(f"needs {CHROMIUM} (apt-get install chromium) and the playwright package", allow_module_level=True)

WALK_OVERLAYS = {"com", "com_ground", "zmp_planned", "zmp_executed", "dcm_planned", "dcm_executed",
                 "support_polygon", "footsteps_planned", "footprints", "swing_left", "swing_right"}
BALANCE_OVERLAYS = {"com", "com_ground", "com_reference", "zmp_executed", "dcm_executed", "support_polygon",
                    "footprints", "swing_left", "swing_right"}
PHYSICS_OVERLAYS = {"com", "com_ground", "cop", "zmp_planned", "dcm_planned", "dcm_executed", "support_polygon",
                    "footsteps_planned", "footprints", "swing_left", "swing_right", "contact_force_left",
                    "contact_force_right", "push"}

# JavaScript helpers evaluated in the page (meshcat's three.js scene is y-up: meshcat z = three.js y).
OVERLAY_NAMES = "() => Object.keys(viewer.scene_tree.find(['meshcat', 'overlays']).children)"
LEGEND_NAMES = ("() => Array.from(document.querySelectorAll('#wbc-legend div')).map(d => d.textContent.trim())")
ROBOT_MIN_Z = """(name) => {
  let z = Infinity;
  viewer.scene.updateMatrixWorld(true);
  viewer.scene_tree.find(['meshcat', name]).object.traverse(o => {
    if (o.isMesh && o.geometry) {
      o.geometry.computeBoundingBox();
      z = Math.min(z, o.geometry.boundingBox.clone().applyMatrix4(o.matrixWorld).min.y);
    } });
  return z;
}"""
GRID_Z = """() => {
  viewer.scene.updateMatrixWorld(true);
  const o = viewer.scene_tree.find(['meshcat', 'floor', 'grid']).object.children[0];
  o.geometry.computeBoundingBox();
  const b = o.geometry.boundingBox.clone().applyMatrix4(o.matrixWorld);
  return [b.min.y, b.max.y, viewer.scene_tree.find(['Grid']).object.visible];
}"""
NEXT_FRAMES = "() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(() => r())))"


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """CLI recordings (and npz logs) of a 2-step walk, the balance `shift` and a 2-step physics walk with a push."""
    folder = tmp_path_factory.mktemp("rec")
    runs = {
        "walk": ["walk", "--steps", "2", "--quiet"],
        "balance": ["balance", "shift", "--quiet"],
        "physics": ["sim", "walk", "--steps", "2", "--push", "100", "--push-time", "1.0", "--quiet"],
    }
    out = {}
    for name, argv in runs.items():
        html, log = folder / f"{name}.html", folder / f"{name}.npz"
        assert main([*argv, "--out", str(html), "--log", str(log)]) == 0, name
        with np.load(log) as z:
            out[name] = (html, z["q"].copy(), z["t"].copy())
    return out


def _shot(page, name: str) -> None:
    folder = os.environ.get("WBC_VIZ_SHOTS")
    if folder:
        Path(folder).mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(Path(folder) / f"{name}.png"))


def _open_recording(browser, path: Path):
    page = browser.new_page(viewport={"width": 1000, "height": 750})
    page.goto(path.as_uri())
    page.wait_for_selector("#meshcat-pane canvas", timeout=WAIT_MS)
    page.wait_for_function("() => window.wbcCommandCount !== undefined || window.wbcError !== undefined",
                           timeout=WAIT_MS)
    assert page.evaluate("() => window.wbcError") is None
    return page


@pytest.mark.parametrize("kind,expected", [("walk", WALK_OVERLAYS), ("balance", BALANCE_OVERLAYS),
                                           ("physics", PHYSICS_OVERLAYS)])
def test_cli_recording_shows_every_overlay_feet_on_the_grid_and_follows_the_base(browser, recordings, kind,
                                                                                 expected):
    html, q, t = recordings[kind]
    page = _open_recording(browser, html)
    try:
        names = set(page.evaluate(OVERLAY_NAMES))
        assert expected <= names, expected - names
        assert expected <= set(page.evaluate(LEGEND_NAMES)), "legend"
        # every overlay node holds a drawable object (sphere, line or arrow)
        for name in expected:
            n = page.evaluate("(name) => { let n = 0; viewer.scene_tree.find(['meshcat', 'overlays', name]).object"
                              ".traverse(o => { if (o.isMesh || o.isLine) n++; }); return n; }", name)
            assert n >= 1, name
        robot = page.evaluate("() => Object.keys(viewer.scene_tree.find(['meshcat']).children)"
                              ".filter(k => k !== 'overlays' && k !== 'floor')")
        assert len(robot) == 1
        # the grid lies flat at z = 0 (1 mm above the floor slab's top), meshcat's own /Grid hidden
        lo, hi, meshcat_grid = page.evaluate(GRID_Z)
        assert lo == pytest.approx(0.001, abs=1e-6) and hi == pytest.approx(0.001, abs=1e-6) and not meshcat_grid
        for when in (0.0, float(t[-1] - t[0])):  # first and last frame: feet on the ground (z = 0), +- 1 cm
            page.evaluate(f"() => {{ viewer.animator.pause(); viewer.animator.seek({when}); }}")
            page.evaluate(NEXT_FRAMES)
            assert abs(page.evaluate(ROBOT_MIN_Z, robot[0])) < 0.01, when
        # the orbit target followed the base: at the last frame it is over the final base position (the
        # base stands still at the end, so the 1 s smoothing has converged), at mid robot height
        page.wait_for_function(f"() => Math.abs(viewer.controls.target.x - {q[-1, 0]}) < 0.02", timeout=WAIT_MS)
        target = page.evaluate("() => viewer.controls.target.toArray()")
        assert -target[2] == pytest.approx(q[-1, 1], abs=0.02)  # three.js z = -meshcat y
        assert target[1] > 0.3  # mid robot height
        if kind != "balance":
            assert q[-1, 0] - q[0, 0] > 0.1  # it walked: the target moved with it
        # seek to mid-run for the screenshot
        page.evaluate(f"() => {{ viewer.animator.seek({0.5 * float(t[-1] - t[0])}); }}")
        page.evaluate(NEXT_FRAMES)
        _shot(page, f"recording_{kind}")
    finally:
        page.close()


def test_live_page_of_a_running_walk(browser):
    """`wbc walk --live`: the page served on 127.0.0.1 shows the walk's overlays while it runs, its camera
    follows the base, and the process stays up after the motion until interrupted (SIGINT: exit code 0)."""
    proc = subprocess.Popen([sys.executable, "-m", "wbc", "walk", "--steps", "8", "--live", "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"},
                            # Ctrl-C as in a terminal: a test runner started in the background (`cmd &` without job
                            # control) ignores SIGINT and its children would inherit that (measured: the walk then
                            # held forever after SIGINT in a `.ci/run` started with `&`)
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # stderr drained all along (an unread pipe would block the process once 64 kB of warnings fill it), shown on
    # failure
    err: list[str] = []
    drain = threading.Thread(target=lambda: err.extend(proc.stderr), daemon=True)
    drain.start()
    try:
        url = None
        for line in proc.stdout:
            if line.startswith("meshcat viewer:"):
                url = line.split()[2]
                break
        assert url and url.startswith("http://127.0.0.1:"), (url, proc.poll())
        page = browser.new_page(viewport={"width": 1000, "height": 750})
        page.goto(url)
        page.wait_for_selector("#meshcat-pane canvas", timeout=WAIT_MS)
        names_ok = (f"() => {sorted(WALK_OVERLAYS)}.every(n => n in "
                    "viewer.scene_tree.find(['meshcat', 'overlays']).children)")
        page.wait_for_function(names_ok, timeout=WAIT_MS)
        page.wait_for_function(f"() => {sorted(WALK_OVERLAYS)}.every(n => "
                               "Array.from(document.querySelectorAll('#wbc-legend div')).some(d => "
                               "d.textContent.trim() === n))", timeout=WAIT_MS)
        robot = page.evaluate("() => Object.keys(viewer.scene_tree.find(['meshcat']).children)"
                              ".filter(k => k !== 'overlays' && k !== 'floor')")
        assert len(robot) == 1
        page.evaluate(NEXT_FRAMES)
        lo, hi, meshcat_grid = page.evaluate(GRID_Z)
        assert lo == pytest.approx(0.001, abs=1e-6) and hi == pytest.approx(0.001, abs=1e-6) and not meshcat_grid
        assert abs(page.evaluate(ROBOT_MIN_Z, robot[0])) < 0.01
        _shot(page, "live_walk_running")
        # the camera follows: the orbit target moves forward with the base (8 steps of 0.15 m: 1.05 m)
        page.wait_for_function("() => viewer.controls.target.x > 0.9", timeout=WAIT_MS)
        # footprints accumulate: both feet at the start and each touchdown
        page.wait_for_function("() => Object.keys(viewer.scene_tree.find(['meshcat', 'overlays', 'footprints'])"
                               ".children).length >= 10", timeout=WAIT_MS)
        # the motion ends; the viewer stays up (no --hold: until Ctrl-C)
        for line in proc.stdout:
            if line.startswith("motion done; meshcat viewer stays up"):
                break
        assert "until Ctrl-C" in line
        assert proc.poll() is None
        page.reload()
        page.wait_for_function(names_ok, timeout=WAIT_MS)  # the scene is still served after the motion
        page.wait_for_function("() => viewer.controls.target.x > 0.9", timeout=WAIT_MS)
        page.evaluate(NEXT_FRAMES)
        _shot(page, "live_walk_held")
        page.close()
        proc.send_signal(signal.SIGINT)
        try:
            code = proc.wait(timeout=120)
        except subprocess.TimeoutExpired:
            code = None
        assert code == 0, f"exit code {code} after SIGINT; stderr: {''.join(err)[-3000:]}"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
