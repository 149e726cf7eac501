"""wbc.viz: offline HTML recordings (checked against Pinocchio and in a real browser) and the live viewer."""

from __future__ import annotations

import base64
import gzip
import importlib.util
import os
import re
import shutil
import struct
import time
from pathlib import Path

import meshcat.animation
import numpy as np
import pinocchio as pin
import pytest
import umsgpack

from wbc.exceptions import InvalidInputError
from wbc.viz import LiveViewer, RealTimePacer, record_html

DT, DURATION, FPS = 0.002, 1.0, 25.0
# Amplitudes (rad) of the right arm and leg sinusoids: arm out to the side with the elbow bending, leg swinging.
RIGHT_JOINTS = {"arm_right_1_joint": 0.4, "arm_right_2_joint": -0.5, "arm_right_4_joint": -0.6,
                "leg_right_1_joint": 0.3, "leg_right_3_joint": -0.5, "leg_right_4_joint": 0.8}
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                 "--disable-background-networking", "--disable-component-update", "--no-first-run",
                 # no name lookups at all (the pages are file:, data: and http://127.0.0.1): a DNS socket of a
                 # lingering browser process fails the ROS 2 tests' loopback guard in the same pytest worker
                 "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1"]


@pytest.fixture(scope="module")
def talos(robots):
    return robots("talos")


@pytest.fixture(scope="module")
def motion(talos):
    """1 s at 500 Hz: right arm and leg joints on a 0.5 Hz sinusoid, base drifting forward; CoM/ZMP overlays."""
    t = np.arange(0.0, DURATION + 1e-9, DT)
    q = np.tile(talos.q_ref, (len(t), 1))
    for name, amplitude in RIGHT_JOINTS.items():
        q[:, talos.model.joints[talos.joint_id(name)].idx_q] += amplitude * np.sin(np.pi * t)
    q[:, 0] += 0.2 * t
    com = np.column_stack([q[:, 0], q[:, 1], np.full(len(t), 0.87)])
    return t, q, {"com": com, "zmp": com * [1.0, 1.0, 0.0]}


SOLE = np.array([[0.1, 0.2, 0.0], [-0.1, 0.2, 0.0], [-0.1, -0.2, 0.0], [0.1, -0.2, 0.0]])


@pytest.fixture(scope="module")
def recording(talos, motion, tmp_path_factory):
    t, q, overlays = motion
    path = tmp_path_factory.mktemp("viz") / "walk.html"
    assert record_html(talos, t, q, path, fps=FPS, overlays=overlays, polygons=[(0.0, 0.5, SOLE)]) == path
    return path


def read_commands(path: Path) -> list[dict]:
    """Decode the meshcat commands embedded in a recording, independently of wbc.viz."""
    html = path.read_text(encoding="utf-8")
    m = re.search(r'<script id="wbc-scene" type="application/octet-stream" data-encoding="(\w+)">([^<]*)</script>',
                  html)
    assert m, "no embedded scene"
    blob = base64.b64decode(m.group(2))
    if m.group(1) == "gzip":
        blob = gzip.decompress(blob)
    commands, offset = [], 0
    while offset < len(blob):
        (n,) = struct.unpack_from("<I", blob, offset)
        commands.append(umsgpack.unpackb(blob[offset + 4: offset + 4 + n]))
        offset += 4 + n
    return commands


def f32(ext) -> np.ndarray:
    return np.frombuffer(ext.data, dtype="<f4").astype(float)


def node_path(robot, geom) -> str:
    return f"/meshcat/{robot.name}/visuals/{geom.name}"


def expected_placement(robot, q: np.ndarray, geom_id: int) -> np.ndarray:
    """4x4 matrix Pinocchio's own MeshcatVisualizer displays: oMg * diag(meshScale)."""
    data, gdata = robot.model.createData(), robot.visual_model.createData()
    pin.forwardKinematics(robot.model, data, q)
    pin.updateGeometryPlacements(robot.model, data, robot.visual_model, gdata)
    scale = robot.visual_model.geometryObjects[geom_id].meshScale
    return gdata.oMg[geom_id].homogeneous @ np.diag([*scale, 1.0])


def mirrored_ids(robot) -> list[int]:
    return [i for i, g in enumerate(robot.visual_model.geometryObjects) if np.prod(g.meshScale) < 0]


def test_recording_is_self_contained(recording):
    html = recording.read_text(encoding="utf-8")
    assert not re.search(r"<(script|link|img|iframe|source)\b[^>]*\b(src|href)\s*=", html, re.I)
    # The only URLs are XML namespace names inside three.js (never fetched).
    assert set(re.findall(r"https?://[^\s\"'<>)]+", html)) <= {"http://www.w3.org/1999/xhtml"}
    assert 3e6 < recording.stat().st_size < 15e6


def test_recording_has_one_animation_with_expected_frames(talos, recording):
    commands = read_commands(recording)
    animations = [c for c in commands if c["type"] == "set_animation"]
    assert len(animations) == 1
    clips = {a["path"]: a["clip"] for a in animations[0]["animations"]}
    n_frames = int(DURATION * FPS) + 1
    for geom in talos.visual_model.geometryObjects:
        tracks = {tr["name"]: tr for tr in clips[node_path(talos, geom)]["tracks"]}
        assert set(tracks) == {".position", ".quaternion"}  # rigid motion only: no scale track
        np.testing.assert_allclose(f32(tracks[".position"]["times"]), np.arange(n_frames) / FPS, atol=1e-6)
        assert f32(tracks[".position"]["values"]).shape == (3 * n_frames,)
        assert f32(tracks[".quaternion"]["values"]).shape == (4 * n_frames,)
    assert {"/meshcat/overlays/com", "/meshcat/overlays/zmp", "/meshcat/overlays/support_polygon/0", "/Cameras/target"} <= set(clips)
    assert {c["duration"] for c in clips.values()} == {DURATION}  # equal durations: clips loop in step
    assert len([c for c in commands if c["type"] == "set_object"]) == talos.visual_model.ngeoms + 3 + 2  # + floor slab and grid
    visible = clips["/meshcat/overlays/support_polygon/0"]["tracks"][0]
    assert visible["values"] == [True, False] and visible["times"] == [0.0, 0.5]


def test_recorded_poses_match_pinocchio_for_mirrored_meshes(talos, motion, recording):
    t, q, _ = motion
    commands = read_commands(recording)
    scale = {c["path"]: np.array(c["value"]) for c in commands
             if c["type"] == "set_property" and c["property"] == "scale"}
    clips = {a["path"]: a["clip"] for a in next(c for c in commands if c["type"] == "set_animation")["animations"]}
    mirrored = mirrored_ids(talos)
    assert len(mirrored) >= 13  # Talos: right arm (7) and right leg (6) meshes have meshScale (1, -1, 1)
    for frame in (7, 12, 25):
        q_frame = q[np.argmin(np.abs(t - frame / FPS))]
        for gid, geom in enumerate(talos.visual_model.geometryObjects):
            path = node_path(talos, geom)
            tracks = {tr["name"]: tr for tr in clips[path]["tracks"]}
            x, y, z, w = f32(tracks[".quaternion"]["values"]).reshape(-1, 4)[frame]
            R = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
            p = f32(tracks[".position"]["values"]).reshape(-1, 3)[frame]
            expected = expected_placement(talos, q_frame, gid)
            assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-6)  # a proper rotation
            np.testing.assert_allclose(R @ np.diag(scale[path]), expected[:3, :3], atol=1e-6, err_msg=path)
            np.testing.assert_allclose(p, expected[:3, 3], atol=1e-6, err_msg=path)
    # Negative control: meshcat.animation's own quaternion of the scaled matrix cannot reproduce a mirror.
    M = expected_placement(talos, q[0], mirrored[0])
    x, y, z, w = meshcat.animation.js_quaternion(M)
    naive = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
    assert np.abs(naive - M[:3, :3]).max() > 0.5


def test_uncompressed_recording_holds_the_same_scene(talos, motion, recording, tmp_path):
    t, q, overlays = motion
    plain = record_html(talos, t, q, tmp_path / "plain.html", fps=FPS, overlays=overlays,
                        polygons=[(0.0, 0.5, SOLE)], compress=False)
    strip = lambda cmds: [{k: v for k, v in c.items() if k != "object"} for c in cmds]  # noqa: E731 (uuids)
    assert strip(read_commands(plain)) == strip(read_commands(recording))


def test_sparse_input_keeps_every_sample(talos, tmp_path):
    t = np.arange(0.0, 1.0 + 1e-9, 0.1)
    anim = next(c for c in read_commands(record_html(talos, t, np.tile(talos.q_ref, (len(t), 1)),
                                                     tmp_path / "s.html", fps=25.0))
                if c["type"] == "set_animation")
    assert len(f32(anim["animations"][0]["clip"]["tracks"][0]["times"])) == len(t)


@pytest.mark.parametrize("case", ["q_shape", "t_order", "overlay_shape", "fps", "nan", "quaternion", "polygon"])
def test_record_html_rejects_bad_input(talos, tmp_path, case):
    t = np.arange(0.0, 0.1, DT)
    q = np.tile(talos.q_ref, (len(t), 1))
    kwargs = {}
    if case == "q_shape":
        q = q[:, :-1]
    elif case == "t_order":
        t = t[::-1]
    elif case == "overlay_shape":
        kwargs["overlays"] = {"com": np.zeros((len(t), 2))}
    elif case == "fps":
        kwargs["fps"] = 0.0
    elif case == "nan":
        q[3, 10] = np.nan
    elif case == "quaternion":
        q[:, 3:7] = [0.0, 0.0, 0.0, 2.0]
    elif case == "polygon":
        kwargs["polygons"] = [(0.5, 0.1, SOLE)]
    with pytest.raises(InvalidInputError):
        record_html(talos, t, q, tmp_path / "bad.html", **kwargs)


def _browser_missing() -> str | None:
    if not Path(CHROMIUM).exists():
        return f"{CHROMIUM} not installed (apt-get install -y chromium)"
    if importlib.util.find_spec("playwright") is None:
        return "the playwright Python package is not installed (pip install playwright)"
    return None


@pytest.mark.skipif(_browser_missing() is not None, reason=str(_browser_missing()))
def test_recording_renders_offline_in_chromium(talos, motion, recording, tmp_path):
    from playwright.sync_api import sync_playwright

    t, q, _ = motion
    n_meshes = talos.visual_model.ngeoms + 2 + 1  # robot + CoM and ZMP spheres + floor slab
    frame = 12
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": 1000, "height": 750})
            outside = []

            def offline(route):
                if route.request.url.startswith(("file:", "data:", "blob:")):
                    return route.continue_()
                outside.append(route.request.url)
                return route.abort()

            page.route("**/*", offline)
            page.goto(recording.as_uri())
            page.wait_for_selector("#meshcat-pane canvas", timeout=20_000)
            count_js = "() => { let n = 0; window.viewer.scene.traverse(o => { if (o.isMesh) n++; }); return n; }"
            page.wait_for_function(f"() => window.wbcError !== undefined || ({count_js})() >= {n_meshes}",
                                   timeout=20_000)
            assert page.evaluate("() => window.wbcError") is None
            assert page.evaluate(count_js) == n_meshes
            # The ground: meshcat's /Grid hidden, our slab's top face at z = 0 (meshcat world) under the feet.
            assert page.evaluate("() => viewer.scene_tree.find(['Grid']).object.visible") is False
            # (world matrices brought up to date first: three.js updates them when it renders, and under load the
            # page may not have rendered since the slab's transform was set — CI read z = 0 once)
            slab = np.array(page.evaluate(
                "() => { viewer.scene.updateMatrixWorld(true);"
                " return viewer.scene_tree.find(['meshcat', 'floor', 'plane']).object"
                ".matrixWorld.clone().premultiply(viewer.scene.matrixWorld.clone().invert()).elements; }")
            ).reshape(4, 4).T
            assert slab[2, 3] == pytest.approx(-0.001, abs=1e-9)  # 2 mm thick slab: top at z = 0
            assert page.evaluate("() => !!document.getElementById('wbc-legend')")
            # Freeze the animation on a key frame; read what three.js will draw for mirrored meshes.
            page.evaluate(f"() => {{ viewer.animator.pause(); viewer.animator.seek({frame / FPS}); }}")
            page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
            q_frame = q[np.argmin(np.abs(t - frame / FPS))]
            for gid in mirrored_ids(talos):
                name = talos.visual_model.geometryObjects[gid].name
                elements = page.evaluate(
                    f"() => viewer.scene_tree.find(['meshcat', '{talos.name}', 'visuals', '{name}']).object"
                    ".matrixWorld.clone().premultiply(viewer.scene.matrixWorld.clone().invert()).elements")
                shown = np.array(elements).reshape(4, 4).T  # three.js stores column-major
                np.testing.assert_allclose(shown, expected_placement(talos, q_frame, gid), atol=1e-5, err_msg=name)
            page.evaluate("() => new Promise(r => setTimeout(() => requestAnimationFrame(() => r()), 300))")
            shot = tmp_path / "walk.png"
            page.screenshot(path=str(shot))
        finally:
            browser.close()
    assert outside == []  # nothing fetched from the network
    assert shot.stat().st_size > 10_000
    if os.environ.get("WBC_VIZ_SCREENSHOT"):
        shutil.copy(shot, os.environ["WBC_VIZ_SCREENSHOT"])


def test_live_viewer_never_blocks_the_caller(talos):
    viewer = LiveViewer(talos, fps=25.0)
    server = viewer.server_process
    try:
        assert server is not None and server.poll() is None
        assert viewer.url.startswith("http://127.0.0.1:")
        q = talos.q_ref.copy()
        for k in range(500):  # update() only posts the latest frame (its latency is in benchmarks/)
            q[0] = 0.001 * k
            viewer.update(q, k * DT, overlays={"com": q[:3]})
        for _ in range(600):  # wait for the display thread (up to 30 s on a loaded machine: not a speed check)
            if viewer.frames_displayed > 0 or viewer.error is not None:
                break
            time.sleep(0.05)
        assert viewer.frames_displayed > 0 and viewer.error is None
        with pytest.raises(InvalidInputError):
            viewer.update(q[:-1])
    finally:
        viewer.close()
    assert not viewer.running
    assert server.poll() is not None  # the meshcat server subprocess was killed
    viewer.close()  # idempotent


def test_live_viewer_draws_the_terrain(talos):
    """`LiveViewer(robot, terrain=...)`: the scene its meshcat server holds (read back by a second client, as a
    browser gets it) has one box per stair tread at the terrain's sizes and centres, under /meshcat/terrain."""
    import contextlib
    import io

    import meshcat

    from wbc.terrain import parse_terrain

    terrain = parse_terrain("stairs:0.1:0.3:3:updown")
    viewer = LiveViewer(talos, fps=25.0, terrain=terrain)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            html = meshcat.Visualizer(zmq_url=viewer.zmq_url).static_html()
    finally:
        viewer.close()
    blobs = [base64.b64decode(b) for b in re.findall(r"base64,([A-Za-z0-9+/=]+)", html)]
    commands = [umsgpack.unpackb(b) for b in blobs if b"/meshcat/terrain/" in b]  # the terrain's scene commands
    boxes = {c["path"]: c for c in commands if c.get("type") == "set_object" and "/meshcat/terrain/box_" in c["path"]}
    poses = {c["path"]: c for c in commands if c.get("type") == "set_transform"
             and "/meshcat/terrain/box_" in c["path"]}
    assert len(terrain.boxes) == 5 and sorted(boxes) == [f"/meshcat/terrain/box_{i}" for i in range(5)]
    for i, box in enumerate(terrain.boxes):
        geom = boxes[f"/meshcat/terrain/box_{i}"]["object"]["geometries"][0]
        assert [geom["width"], geom["height"], geom["depth"]] == pytest.approx(list(box.size))
        T = np.array(poses[f"/meshcat/terrain/box_{i}"]["matrix"], dtype=float).reshape(4, 4).T  # column-major
        assert T[:3, 3] == pytest.approx(list(box.center))


def test_connecting_to_a_missing_server_fails_fast(talos):
    with pytest.raises(ConnectionError):
        LiveViewer(talos, zmq_url="tcp://127.0.0.1:1")


def test_real_time_pacer_keeps_wall_clock(monkeypatch):
    """Deterministic: a fake clock replaces perf_counter/sleep in wbc.viz.live (no wall-clock assertion)."""
    import wbc.viz.live as live

    clock = {"t": 100.0}
    slept = []

    def fake_sleep(s):
        slept.append(s)
        clock["t"] += s

    monkeypatch.setattr(live.time, "perf_counter", lambda: clock["t"])
    monkeypatch.setattr(live.time, "sleep", fake_sleep)
    pacer = RealTimePacer()
    for k in range(100):
        pacer.wait(k * 0.005)
        clock["t"] += 0.001  # 1 ms of work per tick
    # absolute deadlines: tick 99 is due 0.495 s after tick 0, whatever the work per tick
    assert clock["t"] - 100.0 == pytest.approx(0.495 + 0.001, abs=1e-9)
    assert all(s == pytest.approx(0.004) for s in slept[1:])
    clock["t"] += 0.2  # the loop falls behind: re-anchored, no burst of catch-up ticks
    assert pacer.wait(100 * 0.005) > 0.1 and pacer.late_ticks == 1
    assert pacer.wait(101 * 0.005) == 0.0
    with pytest.raises(InvalidInputError):
        RealTimePacer(speed=0.0)
