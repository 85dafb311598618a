"""The operator page in a real browser (headless Chromium driven by selenium) against the
real daemon driving the simulated robot: the page shows the map and the robot, a click on
the map sends a goal, and the robot reaches it; a screenshot mid-drive is kept. On a phone's
390 x 844 touch screen: the stop button, tapped while driving, has the chassis read "0 0" within
100 ms of the stop reaching the daemon and holds the robot until released; a page left
open across a restart takes a tapped goal to the new daemon; a pinch zooms and sends
nothing."""

from __future__ import annotations

import asyncio
import json
import math
import shutil
import signal
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path
from typing import Any

import pytest
from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.support import expected_conditions as ec
from selenium.webdriver.support.wait import WebDriverWait

from navd.sim import Session, free_port, from_shapes, session
from navd.wire import (
    GoalFrame,
    GoalStatusFrame,
    InitialPoseFrame,
    StatusFrame,
    SubscribeFrame,
)
from tests.e2e.test_scenarios import HALL

pytestmark = pytest.mark.e2e

CHROMIUM = shutil.which("chromium")
CHROMEDRIVER = shutil.which("chromedriver")
GOAL = (5.5, 0.0)


# A phone's screen in CSS pixels (an iPhone 12 to 14's), with touch: the page as an operator
# in the field holds it
PHONE = {"width": 390, "height": 844, "pixelRatio": 3.0, "touch": True}


@contextmanager
def browser(profile: Path, *, phone: bool = False) -> Iterator[Any]:
    """Headless Chromium with a fresh profile, kept off the network it cannot reach; with
    ``phone``, a 390 x 844 touch screen."""
    if CHROMIUM is None or CHROMEDRIVER is None:
        pytest.skip(
            "Debian's chromium and chromium-driver are not installed (the set-up installs them "
            "when run as root with apt)"
        )
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--window-size=1200,800",
        f"--user-data-dir={profile}",
    ):
        options.add_argument(flag)
    if phone:
        options.add_experimental_option("mobileEmulation", {"deviceMetrics": PHONE})
    driver = webdriver.Chrome(options=options, service=Service(executable_path=CHROMEDRIVER))
    try:
        yield driver
    finally:
        driver.quit()


def _wait(driver: Any, script: str, timeout_s: float) -> Any:
    """Poll ``script`` in the page until it returns something truthy."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = driver.execute_script(script)
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"the page never answered {script!r} within {timeout_s} s")


def _on_screen(driver: Any, x_m: float, y_m: float) -> tuple[int, int]:
    """[px] where the page draws the map point (x_m, y_m), in the viewport."""
    px, py = driver.execute_script(
        "const [x, y] = navd.mapToScreen(arguments[0], arguments[1]);"
        "const r = document.getElementById('map').getBoundingClientRect();"
        "return [Math.round(r.left + x), Math.round(r.top + y)];",
        x_m,
        y_m,
    )
    return int(px), int(py)


def _click_map(driver: Any, x_m: float, y_m: float) -> None:
    """Click the map where the page draws (x_m, y_m)."""
    px, py = _on_screen(driver, x_m, y_m)
    actions = ActionChains(driver)
    actions.w3c_actions.pointer_action.move_to_location(px, py).click()
    actions.perform()


def _tap(driver: Any, x_px: int, y_px: int) -> None:
    """One finger down and up at (x_px, y_px) of the viewport: a tap."""
    from selenium.webdriver.common.actions import interaction
    from selenium.webdriver.common.actions.action_builder import ActionBuilder

    actions = ActionBuilder(driver)
    finger = actions.add_pointer_input(interaction.POINTER_TOUCH, "finger")
    finger.create_pointer_move(x=x_px, y=y_px, origin="viewport")
    finger.create_pointer_down()
    finger.create_pause(0.08)
    finger.create_pointer_up(0)
    actions.perform()


def _tap_map(driver: Any, x_m: float, y_m: float) -> None:
    """Tap the map where the page draws (x_m, y_m)."""
    px, py = _on_screen(driver, x_m, y_m)
    _tap(driver, px, py)


def _tap_element(driver: Any, element_id: str) -> None:
    """Tap the middle of the element ``element_id``, which must be on the screen."""
    px, py, seen = driver.execute_script(
        "const r = document.getElementById(arguments[0]).getBoundingClientRect();"
        "return [Math.round(r.left + r.width / 2), Math.round(r.top + r.height / 2),"
        "  r.width > 0 && r.bottom <= window.innerHeight && r.right <= window.innerWidth];",
        element_id,
    )
    assert seen, f"#{element_id} is not on the phone's screen"
    _tap(driver, px, py)


async def _status_until(s: Session, wanted: Any, limit_s: float) -> Any:
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        s.check()
        try:
            frame = await s.control.receive(1.0)
        except TimeoutError:
            continue
        if wanted(frame):
            return frame
    raise AssertionError(f"nothing wanted came within {limit_s} s")


async def test_a_click_on_the_page_sends_a_goal_the_robot_reaches(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    page_port = free_port()
    overrides = {"viz": {"port": free_port(), "page_port": page_port}}
    async with session(world, tmp_path / "run", overrides=overrides) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        s.control.send(SubscribeFrame(rate_hz=5))
        with browser(tmp_path / "profile") as driver:
            await asyncio.to_thread(driver.get, f"http://127.0.0.1:{page_port}/")
            ready = "return document.body.dataset.ready === '1'"
            await asyncio.to_thread(_wait, driver, ready, 30.0)
            await asyncio.to_thread(_click_map, driver, *GOAL)
            # The page's goal goes through the bus like any other: the planner takes it.
            active = await _status_until(
                s,
                lambda f: isinstance(f, GoalStatusFrame) and f.state == "active",
                10.0,
            )
            assert active.goal_id.startswith("viewer-")
            await _status_until(
                s,
                lambda f: isinstance(f, StatusFrame) and f.pose is not None and f.pose.x > 2.0,
                60.0,
            )
            shot = tmp_path / "operator-page-mid-drive.png"
            await asyncio.to_thread(driver.save_screenshot, str(shot))
            drawn = await asyncio.to_thread(
                driver.execute_script,
                "return [navd.state.route !== null,"
                " Object.values(navd.state.scans).reduce((n, s) => n + s.points.length, 0),"
                " document.getElementById('goal').textContent,"
                " document.getElementById('safety').textContent]",
            )
            final = await _status_until(
                s,
                lambda f: (
                    isinstance(f, GoalStatusFrame)
                    and f.goal_id == active.goal_id
                    and f.state in ("reached", "failed", "canceled")
                ),
                60.0,
            )
            # the goal over, its route and marker go from the picture
            gone = "return navd.state.route === null && navd.state.goal === null"
            await asyncio.to_thread(_wait, driver, gone, 10.0)
    assert final.state == "reached", final
    _, x, y, _ = s.sim.truth[-1]
    assert math.hypot(x - GOAL[0], y - GOAL[1]) <= 0.3
    assert s.sim.body.collisions == 0
    has_route, scan_points, goal_text, safety_text = drawn
    assert has_route and scan_points > 100
    assert active.goal_id in goal_text and "active" in goal_text
    assert safety_text == "free to move"
    assert shot.stat().st_size > 10_000  # a picture, kept in the test's folder


async def test_a_replaced_goal_leaves_the_new_goal_drawn_and_a_reload_draws_no_ended_goal(
    tmp_path: Path,
) -> None:
    world = from_shapes(HALL, "hall")
    page_port = free_port()
    overrides = {"viz": {"port": free_port(), "page_port": page_port}}
    async with session(world, tmp_path / "run", overrides=overrides) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        s.control.send(SubscribeFrame(rate_hz=5))
        with browser(tmp_path / "profile") as driver:
            await asyncio.to_thread(driver.get, f"http://127.0.0.1:{page_port}/")
            ready = "return document.body.dataset.ready === '1'"
            await asyncio.to_thread(_wait, driver, ready, 30.0)
            s.control.send(GoalFrame(goal_id="first", x=GOAL[0], y=GOAL[1]))
            await _status_until(
                s, lambda f: isinstance(f, GoalStatusFrame) and f.goal_id == "first"
                and f.state == "active", 30.0,
            )  # fmt: skip
            s.control.send(GoalFrame(goal_id="second", x=GOAL[0] - 1.0, y=GOAL[1]))
            await _status_until(
                s, lambda f: isinstance(f, GoalStatusFrame) and f.goal_id == "first"
                and f.state == "canceled", 30.0,
            )  # fmt: skip
            # the first goal's end has long reached the page once the robot has driven on
            x0 = s.sim.body.x_m
            await _status_until(
                s, lambda f: isinstance(f, StatusFrame) and s.sim.body.x_m > x0 + 1.0, 60.0
            )
            drawn = await asyncio.to_thread(
                driver.execute_script,
                "return [navd.state.goal && navd.state.goal.goal_id,"
                " navd.state.goalStatus.goal_id]",
            )
            assert drawn == ["second", "second"]
            await _status_until(
                s, lambda f: isinstance(f, GoalStatusFrame) and f.goal_id == "second"
                and f.state == "reached", 60.0,
            )  # fmt: skip
            await asyncio.to_thread(driver.refresh)
            await asyncio.to_thread(_wait, driver, ready, 30.0)
            seen = "return navd.state.goalStatus && navd.state.goalStatus.state === 'reached'"
            await asyncio.to_thread(_wait, driver, seen, 30.0)
            await asyncio.to_thread(_wait, driver, "return navd.state.info !== null", 30.0)
            after_reload = await asyncio.to_thread(
                driver.execute_script, "return [navd.state.goal, navd.state.route]"
            )
            assert after_reload == [None, None]  # the ended goal's marker and route not drawn


def _record_wheel_lines(s: Session) -> list[tuple[float, bytes]]:
    """[(wall clock s, line)] each wheel line the simulated chassis reads from now on."""
    seen: list[tuple[float, bytes]] = []
    take = s.sim.robot.take_wheel_bytes
    pending = bytearray()

    def recording(data: bytes, now: float) -> None:
        at = time.time()
        pending.extend(data)
        while b"\n" in pending:
            line, _, rest = bytes(pending).partition(b"\n")
            seen.append((at, line))
            pending[:] = rest
        take(data, now)

    s.sim.robot.take_wheel_bytes = recording  # type: ignore[method-assign]
    return seen


def _logged_at(log: Path, event: str, needle: str) -> float:
    """[s, wall clock] when the daemon's JSON log first said ``event`` with ``needle`` in it."""
    for line in log.read_text(errors="replace").splitlines():
        if f'"event": "{event}"' in line and needle in line:
            stamp = json.loads(line)["timestamp"].replace("Z", "+00:00")
            return datetime.fromisoformat(stamp).timestamp()
    raise AssertionError(f"the daemon never logged {event} with {needle!r}")


async def test_the_pages_stop_button_stops_a_driving_robot_and_holds_it(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    page_port = free_port()
    overrides = {"viz": {"port": free_port(), "page_port": page_port}}
    async with session(world, tmp_path / "run", overrides=overrides) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        s.control.send(SubscribeFrame(rate_hz=5))
        lines = _record_wheel_lines(s)
        with browser(tmp_path / "profile", phone=True) as driver:
            await asyncio.to_thread(driver.get, f"http://127.0.0.1:{page_port}/")
            ready = "return document.body.dataset.ready === '1'"
            await asyncio.to_thread(_wait, driver, ready, 30.0)
            s.control.send(GoalFrame(x=GOAL[0], y=GOAL[1]))
            await _status_until(
                s,
                lambda f: isinstance(f, StatusFrame) and f.pose is not None and f.pose.x > 1.0,
                60.0,
            )
            assert s.sim.body.linear_mps > 0.1, "driving when the stop is tapped"
            await asyncio.to_thread(_tap_element, driver, "estop")
            held = await _status_until(
                s,
                lambda f: (
                    isinstance(f, StatusFrame)
                    and any(r.startswith("emergency stop by viewer-") for r in f.diagnostics.safety)
                ),
                10.0,
            )
            assert held is not None
            deadline = time.monotonic() + 5.0
            while s.sim.body.linear_mps != 0.0 and time.monotonic() < deadline:
                await asyncio.sleep(0.05)  # braking within the body's limits
            stood_at = s.sim.body.x_m
            release = "return !document.getElementById('estop-release').hidden"
            await asyncio.to_thread(_wait, driver, release, 10.0)
            await asyncio.sleep(2.0)  # the goal is still on: held, the robot does not take it up
            assert s.sim.body.x_m == pytest.approx(stood_at, abs=0.01)
            assert s.sim.body.linear_mps == 0.0
            await asyncio.to_thread(_tap_element, driver, "estop-release")
            await _status_until(
                s, lambda f: isinstance(f, StatusFrame) and not f.diagnostics.safety, 10.0
            )
            hidden = "return document.getElementById('estop-release').hidden"
            await asyncio.to_thread(_wait, driver, hidden, 10.0)
    # The stop reached the daemon when its safety gate said so; the chassis read "0 0" after.
    heard = _logged_at(tmp_path / "run" / "navd.log", "safety_hold", "emergency stop by viewer-")
    first_zero = next(at for at, line in lines if at >= heard and line == b"0 0")
    moving_before = [line for at, line in lines if at < heard][-3:]
    assert all(line != b"0 0" for line in moving_before), moving_before
    assert first_zero - heard <= 0.100, f"first 0 0 {1000 * (first_zero - heard):.1f} ms after"


async def test_a_page_left_open_across_a_restart_commands_the_new_daemon(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    page_port = free_port()
    overrides = {"viz": {"port": free_port(), "page_port": page_port}}
    work = tmp_path / "run"
    async with session(world, work, overrides=overrides) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        with browser(tmp_path / "profile", phone=True) as driver:
            await asyncio.to_thread(driver.get, f"http://127.0.0.1:{page_port}/")
            ready = "return document.body.dataset.ready === '1'"
            await asyncio.to_thread(_wait, driver, ready, 30.0)
            old_token = await asyncio.to_thread(
                driver.execute_script, "return window.navdConfig.command_token"
            )
            s.daemon.send_signal(signal.SIGTERM)
            await s.daemon.wait()
            log = tmp_path / "restarted.log"
            with log.open("wb") as out:
                again = await asyncio.create_subprocess_exec(
                    sys.executable, "-m", "navd", "run", "--config", str(work / "navd.toml"),
                    stdout=out, stderr=out,
                )  # fmt: skip
            try:
                fresh = (
                    f"return window.navdConfig.command_token !== {old_token!r}"
                    " && navd.state.connected"
                )
                await asyncio.to_thread(_wait, driver, fresh, 60.0)
                await asyncio.to_thread(_wait, driver, "return navd.state.map !== null", 60.0)
                await asyncio.to_thread(_tap_map, driver, 1.0, 0.0)
                deadline = time.monotonic() + 30.0
                said = ""
                while "viewer-" not in said and time.monotonic() < deadline:
                    await asyncio.sleep(0.2)
                    said = "\n".join(
                        line
                        for line in log.read_text(errors="replace").splitlines()
                        if '"goal"' in line or "viewer_command_refused" in line
                    )
                assert "viewer_command_refused" not in said and "viewer-" in said, said
            finally:
                again.send_signal(signal.SIGTERM)
                await asyncio.wait_for(again.wait(), 30.0)


def _pinch(driver: Any, spread_px: int) -> None:
    """Two fingers on the map's middle, moved apart by ``spread_px`` each, then lifted."""
    from selenium.webdriver.common.actions import interaction
    from selenium.webdriver.common.actions.action_builder import ActionBuilder

    box = driver.execute_script(
        "const r = document.getElementById('map').getBoundingClientRect();"
        "return [Math.round(r.left + r.width / 2), Math.round(r.top + r.height / 2)];"
    )
    cx, cy = box
    actions = ActionBuilder(driver)
    fingers = [
        actions.add_pointer_input(interaction.POINTER_TOUCH, name) for name in ("one", "two")
    ]
    for finger, side in zip(fingers, (-1, 1), strict=True):
        finger.create_pointer_move(x=cx + side * 30, y=cy, origin="viewport")
        finger.create_pointer_down()
    for step in range(1, 6):
        for finger, side in zip(fingers, (-1, 1), strict=True):
            finger.create_pointer_move(
                duration=50, x=cx + side * (30 + spread_px * step // 5), y=cy, origin="viewport"
            )
    for finger in fingers:
        finger.create_pointer_up(0)
    actions.perform()


async def test_a_pinch_zooms_the_map_and_sends_nothing(tmp_path: Path) -> None:
    world = from_shapes(HALL, "hall")
    page_port = free_port()
    overrides = {"viz": {"port": free_port(), "page_port": page_port}}
    async with session(world, tmp_path / "run", overrides=overrides) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        s.control.send(SubscribeFrame(rate_hz=5))
        with browser(tmp_path / "profile", phone=True) as driver:
            await asyncio.to_thread(driver.get, f"http://127.0.0.1:{page_port}/")
            ready = "return document.body.dataset.ready === '1' && navd.state.map !== null"
            await asyncio.to_thread(_wait, driver, ready, 30.0)
            # fitted: what is known of the map fills the canvas, the unknown margin does not
            filled = await asyncio.to_thread(
                driver.execute_script,
                "const m = navd.state.map, [c0, r0, c1, r1] = m.known;"
                "const [ax, ay] = navd.mapToScreen(m.origin.x + c0 * m.resolution,"
                "  m.origin.y + r0 * m.resolution);"
                "const [bx, by] = navd.mapToScreen(m.origin.x + c1 * m.resolution,"
                "  m.origin.y + r1 * m.resolution);"
                "const c = document.getElementById('map');"
                "return [(bx - ax) / c.clientWidth, (ay - by) / c.clientHeight];",
            )
            assert max(filled) >= 0.9 and min(filled) > 0.0 and max(filled) <= 1.0, filled
            before = await asyncio.to_thread(driver.execute_script, "return navd.view.scale")
            said = await asyncio.to_thread(
                driver.execute_script, "return document.getElementById('message').textContent"
            )
            await asyncio.to_thread(_pinch, driver, 150)
            after = await asyncio.to_thread(driver.execute_script, "return navd.view.scale")
            assert after > 1.5 * before  # the fingers spread: zoomed in
            # nothing was sent: no goal, no pose, not even when the fingers lift one by one
            deadline = time.monotonic() + 2.0
            while time.monotonic() < deadline:
                s.check()
                try:
                    frame = await s.control.receive(0.5)
                except TimeoutError:
                    continue
                assert not isinstance(frame, GoalStatusFrame), frame
            message = "return document.getElementById('message').textContent"
            assert await asyncio.to_thread(driver.execute_script, message) == said


def _drag_map(driver: Any, start_m: tuple[float, float], end_m: tuple[float, float]) -> None:
    """One finger pressed on the map at ``start_m``, moved to ``end_m`` and lifted."""
    from selenium.webdriver.common.actions import interaction
    from selenium.webdriver.common.actions.action_builder import ActionBuilder

    (x0, y0), (x1, y1) = _on_screen(driver, *start_m), _on_screen(driver, *end_m)
    actions = ActionBuilder(driver)
    finger = actions.add_pointer_input(interaction.POINTER_TOUCH, "finger")
    finger.create_pointer_move(x=x0, y=y0, origin="viewport")
    finger.create_pointer_down()
    for step in range(1, 6):
        x, y = x0 + (x1 - x0) * step // 5, y0 + (y1 - y0) * step // 5
        finger.create_pointer_move(duration=40, x=x, y=y, origin="viewport")
    finger.create_pointer_up(0)
    actions.perform()


def _poses_set(log: Path) -> list[tuple[float, float]]:
    """Where the daemon was told the robot is, in its log so far."""
    poses = []
    for line in log.read_text(errors="replace").splitlines():
        if '"initial_pose"' in line:
            event = json.loads(line)
            poses.append((float(event["x"]), float(event["y"])))
    return poses


async def test_a_drag_on_a_phone_sets_the_pose_only_once_confirmed(tmp_path: Path) -> None:
    # a slipping finger used to set the robot's pose at once; on a touch screen it now asks
    world = from_shapes(HALL, "hall")
    page_port = free_port()
    overrides = {"viz": {"port": free_port(), "page_port": page_port}}
    work = tmp_path / "run"
    async with session(world, work, overrides=overrides) as s:
        s.control.send(InitialPoseFrame(x=0.0, y=0.0, yaw=0.0, std_xy=0.02))
        log = work / "navd.log"
        with browser(tmp_path / "profile", phone=True) as driver:
            await asyncio.to_thread(driver.get, f"http://127.0.0.1:{page_port}/")
            ready = "return document.body.dataset.ready === '1' && navd.state.map !== null"
            await asyncio.to_thread(_wait, driver, ready, 30.0)
            before = _poses_set(log)
            for answer in ("dismiss", "accept"):
                await asyncio.to_thread(_drag_map, driver, (2.0, 0.0), (2.0, 1.0))
                alert = await asyncio.to_thread(
                    lambda: WebDriverWait(driver, 5.0).until(ec.alert_is_present())
                )
                assert alert.text.startswith("Set the robot's pose to (")  # where it goes
                await asyncio.to_thread(getattr(alert, answer))
                if answer == "dismiss":
                    message = "return document.getElementById('message').textContent"
                    said = await asyncio.to_thread(_wait, driver, message, 5.0)
                    assert said == "pose not sent"
                    await asyncio.sleep(1.0)  # time for a pose to have arrived, had it gone
                    assert _poses_set(log) == before
            deadline = time.monotonic() + 15.0
            while len(_poses_set(log)) == len(before) and time.monotonic() < deadline:
                s.check()
                await asyncio.sleep(0.2)
            x, y = _poses_set(log)[-1]
            assert math.hypot(x - 2.0, y - 0.0) < 0.15  # where the finger went down
