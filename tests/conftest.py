"""Suite-wide setup: headless rendering, and a guard that fails any non-loopback connection.

The guard patches ``socket.socket.connect``, ``connect_ex``, ``sendto`` and
``socket.create_connection`` for the whole session. A connection to anything but loopback
(127.0.0.0/8, ::1, "localhost") or an AF_UNIX path raises ``NonLoopbackConnectionError``
naming the address, before the real call (and before any DNS lookup). Every blocked attempt
is also recorded, and the test during which it happened fails at teardown even if the code
under test swallowed the exception.
"""

from __future__ import annotations

import ipaddress
import os
import signal
import socket
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")


class NonLoopbackConnectionError(RuntimeError):
    """A test tried to reach a non-loopback address."""


def is_loopback_address(family: int, address: object) -> bool:
    """Whether connecting to ``address`` stays on this machine (loopback or AF_UNIX)."""
    if family == getattr(socket, "AF_UNIX", object()) or isinstance(address, (str, bytes)):
        return True  # AF_UNIX path (or abstract socket name)
    if not isinstance(address, tuple) or not address:
        return False
    host = address[0]
    if isinstance(host, bytes):
        host = host.decode(errors="replace")
    if not isinstance(host, str):
        return False
    if host.lower() == "localhost":
        return True
    try:
        ip = ipaddress.ip_address(host.split("%", 1)[0])
    except ValueError:
        return False  # any other host name would need a DNS lookup: not loopback
    mapped = getattr(ip, "ipv4_mapped", None)
    return ip.is_loopback or (mapped is not None and mapped.is_loopback)


class NetworkGuard:
    """Installs the socket patches and records blocked attempts."""

    error_type = NonLoopbackConnectionError
    allows = staticmethod(is_loopback_address)

    def __init__(self) -> None:
        self.blocked: list[str] = []
        self.real_connect = socket.socket.connect
        self.real_connect_ex = socket.socket.connect_ex
        self.real_sendto = socket.socket.sendto
        self.real_create_connection = socket.create_connection

    def check(self, family: int, address: object, via: str) -> None:
        if not is_loopback_address(family, address):
            msg = (
                f"network access blocked by tests/conftest.py: {via} to non-loopback address "
                f"{address!r}"
            )
            self.blocked.append(msg)
            raise NonLoopbackConnectionError(msg)

    def install(self, mp: pytest.MonkeyPatch) -> None:
        guard = self

        def connect(sock, address):
            guard.check(sock.family, address, "socket.connect")
            return guard.real_connect(sock, address)

        def connect_ex(sock, address):
            guard.check(sock.family, address, "socket.connect_ex")
            return guard.real_connect_ex(sock, address)

        def sendto(sock, data, *args):
            if args:  # sendto(data, address) or sendto(data, flags, address)
                guard.check(sock.family, args[-1], "socket.sendto")
            return guard.real_sendto(sock, data, *args)

        def create_connection(address, *args, **kwargs):
            guard.check(socket.AF_INET, address, "socket.create_connection")
            return guard.real_create_connection(address, *args, **kwargs)

        mp.setattr(socket.socket, "connect", connect)
        mp.setattr(socket.socket, "connect_ex", connect_ex)
        mp.setattr(socket.socket, "sendto", sendto)
        mp.setattr(socket, "create_connection", create_connection)


def pytest_configure(config) -> None:
    """A run started in the background by a non-interactive shell (``cmd &``, ``nohup``)
    inherits SIGINT ignored, and so would every command the tests start; the tests send
    SIGINT on purpose (Ctrl-C handling), so it gets Python's usual handler back."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


# --- the legs of tools/run_tests.sh: markers given by module, long tests, LeRobot skips ----
#: Modules whose tests measure wall-clock motion or timing of a kit served over the vendor's
#: wire protocol (arms homed within 0.03 rad, 50 fps periods, action timeouts): marked
#: ``serial``. tools/run_tests.sh runs them alone, after the pass spread over the cores by
#: pytest-xdist: beside a busy neighbouring worker a homing test missed its tolerance
#: (2026-11-27), and on a loaded machine (2026-11-28) tests of the last two failed in that
#: pass and passed alone (the first two assert the same kind of tolerance). The other
#: served-kit modules (serve, its signals, teleop, the leaders, clean exits) passed in the
#: parallel pass and stay in it; each module serves on loopback addresses of its own
#: (tests/twin/conftest.py), so modules never clash.
SERIAL_MODULES = (
    "tests/twin/test_kit_world.py",
    "tests/real/test_wire_recover.py",
    "tests/scripts/test_replay_episode_real.py",
    "tests/eval/test_wire_backend.py",
    # a signal sent mid-write: beside a busy worker it once came after the write had ended
    "tests/scripts/test_visualize_eps.py",
    # the vendor's driver streams a move to a served kit: in a parallel run of the whole
    # suite (2026-11-29) a late period let the gripper's target run 28 mm ahead, a fault
    "tests/scripts/test_serve.py",
    # the single arm through the wire: wall-clock control periods, as test_wire_backend
    "tests/eval/test_arm_wire.py",
)

#: Why a ``serial`` test skips in a run spread over the cores (pytest's default here).
SERIAL_SKIP = (
    "serial: wall-clock sensitive (a served kit's timing, a signal mid-write), so it runs "
    "alone, not beside pytest-xdist workers: "
    "python -m pytest -n 0 -m serial (tools/run_tests.sh's leg 2)"
)

#: Modules that run on the Python 3.12 leg too (marked ``py312``; a single test can carry the
#: marker itself): what imports LeRobot or torch in-process, the LeRobot env plugin and the
#: task entry points (``importlib.metadata`` differs by Python version), the import of every
#: public module, and the parts whose libraries the LeRobot venv pins to other versions than
#: the [dev] extra resolves (PyAV 15 encodes the export's videos there, numpy 2.2, torch 2.11;
#: tests/data/test_video.py marks its encoding tests, not its plots).
#: Tests that run LeRobot's tools in a subprocess (``TROSSEN_LEROBOT_PYTHON``) are marked
#: ``once`` and run on the first leg: their LeRobot is the 3.12 venv's whatever runs pytest.
PY312_MODULES = (
    "tests/test_public_api.py",
    "tests/test_import_graph.py",
    "tests/test_cli.py",
    "tests/test_examples.py",
    "tests/tasks/test_task_packages.py",
    "tests/tasks/test_task_in_one_place.py",
    "tests/tasks/test_task_registry.py",
    "tests/data/test_act_loader.py",
    "tests/eval/test_runner.py",
    "tests/eval/test_env.py",
    "tests/eval/test_controller_limits_step.py",
    "tests/eval/test_camera_pose_step.py",
    "tests/eval/test_prepare.py",
    "tests/scripts/test_eval_policy.py",
    "tests/export/test_lerobot_export.py",
    "tests/robot/test_lerobot_keys.py",
)

#: The quick subset (marked ``quick``; ``python -m pytest -m quick``, under 2 minutes on 2
#: cores, docs/testing.md): for each unit of the package (every subpackage, and the top-level
#: modules), test modules or single tests ("path::test_name", all its parameters) that run
#: its main path. tests/test_quick_subset.py checks that the units are the package's (a new
#: subpackage needs an entry), that each entry exists and that the unit is named by one of
#: its entries (the top-level entries name every top-level module between them). No serial
#: module (it skips in a run spread over the cores) and no ``long`` test belongs here.
QUICK: dict[str, tuple[str, ...]] = {
    "(top level)": (
        "tests/test_public_api.py",  # imports every module of the package
        "tests/test_import_graph.py",
        "tests/test_quick_subset.py",  # this list against the package
        "tests/test_utils.py::test_make_sim_env_returns_a_dm_control_environment",
        "tests/test_utils.py::test_asset_path",
        "tests/test_sim_env.py::test_custom_task_runs_unchanged_for_100_steps",
        "tests/test_sim_env.py::test_vendor_recorded_transfer_transfers_the_cube",
        "tests/test_ee_sim_env.py::test_custom_task_runs_unchanged_for_100_steps",
        "tests/test_ee_sim_env.py::test_documented_reward_scores_4_on_scripted_transfers",
        "tests/test_cli.py",
        "tests/test_clip.py",
        "tests/test_errors.py",
        "tests/test_fileio.py",
        "tests/test_images.py",
        "tests/test_names.py",
        "tests/test_processes.py",
        "tests/test_worker_pool.py::test_every_result_comes_back_with_its_position",
        "tests/test_quaternion.py",
        "tests/test_viewer.py",
        "tests/test_demo.py::test_headless_demo_writes_four_pngs",
    ),
    "assets": ("tests/assets/test_models.py", "tests/assets/test_mobile_ai.py"),
    "robot": ("tests/robot/test_robot.py",),
    "sim": ("tests/sim/test_scene.py",),
    "data": ("tests/data/test_writer.py", "tests/data/test_reader.py"),
    "real": ("tests/real/test_replay.py", "tests/real/test_validate.py"),
    "tasks": ("tests/tasks/test_transfer_cube.py",),
    "policies": ("tests/policies/test_scripted.py",),
    "gym": ("tests/gym/test_gym_stepping.py",),
    "collect": (
        "tests/collect/test_pipeline.py::test_full_episode_succeeds_without_images",
        "tests/collect/test_pipeline.py::test_episode_matches_documented_layout",
    ),
    "export": (
        "tests/export/test_lerobot_plan.py",
        "tests/export/test_dataset_settings.py::test_export_writes_the_settings_into_info_json",
    ),
    "train": ("tests/train/test_pose_dataset.py",),
    "eval": (
        "tests/eval/test_scores.py",
        "tests/eval/test_runner.py::test_function_policy_holding_the_start_pose_scores_nothing",
    ),
    "twin": ("tests/twin/test_episode_spool.py", "tests/twin/test_session_recorder.py"),
    "src": ("tests/src/test_controller.py",),
    "scripts": (
        "tests/scripts/test_record_args.py",
        "tests/scripts/test_record_sim_episodes.py::test_records_and_reports_success_line",
    ),
}

#: What ``QUICK`` marks: whole modules, and (module, test name) pairs.
QUICK_MODULES = frozenset(e for entries in QUICK.values() for e in entries if "::" not in e)
QUICK_TESTS = frozenset(
    tuple(e.split("::", 1)) for entries in QUICK.values() for e in entries if "::" in e
)


def _is_quick(module: str, name: str) -> bool:
    """Whether the test ``name`` (its function's name) of ``module`` is in ``QUICK``."""
    return module in QUICK_MODULES or (module, name) in QUICK_TESTS


#: Skip reasons that mean "LeRobot (or its venv) is missing": with TROSSEN_LEROBOT_REQUIRED=1
#: (tools/run_tests.sh sets it) such a skip fails the test instead, so that a LeRobot test
#: cannot skip silently in every leg.
LEROBOT_SKIP_WORDS = ("lerobot", "trossen_lerobot_python")


def pytest_addoption(parser) -> None:
    parser.addoption(
        "--long",
        action="store_true",
        help="also run the tests marked `long` (tools/run_tests.sh, and so CI, runs them)",
    )


REPO = Path(__file__).resolve().parents[1]


def _module_path(item) -> str:
    """The test's module relative to the repository (ValueError outside it)."""
    return Path(item.path).resolve().relative_to(REPO).as_posix()


def pytest_ignore_collect(collection_path: Path, config) -> bool | None:
    """With ``-m quick`` (exactly), a test module with nothing in ``QUICK`` is not collected:
    importing every module would take longer than the quick tests themselves."""
    if config.getoption("markexpr", "") != "quick" or not collection_path.name.startswith("test_"):
        return None
    try:
        module = collection_path.resolve().relative_to(REPO).as_posix()
    except ValueError:
        return None
    if collection_path.suffix != ".py" or not module.startswith("tests/"):
        return None
    return None if module in QUICK_MODULES or any(m == module for m, _ in QUICK_TESTS) else True


def pytest_collection_modifyitems(config, items) -> None:
    """Marks the modules of ``SERIAL_MODULES`` ``serial`` (skipped on a pytest-xdist worker),
    those of ``PY312_MODULES`` ``py312`` and what ``QUICK`` names ``quick``; leaves out the
    tests marked ``long`` unless ``--long`` is given."""
    in_repo = (REPO / "tests" / "conftest.py").resolve() == Path(__file__).resolve()
    quick_files = {e.split("::", 1)[0] for entries in QUICK.values() for e in entries}
    stale = [m for m in (*SERIAL_MODULES, *PY312_MODULES, *quick_files) if not (REPO / m).is_file()]
    if in_repo and stale:  # (not when a test copies this file elsewhere to run pytest there)
        raise pytest.UsageError(f"tests/conftest.py names test modules that do not exist: {stale}")
    # pytest's defaults (pyproject.toml) spread a run over the cores; a serial test there
    # would run beside busy workers, so it skips, saying how to run it alone
    in_xdist_worker = "PYTEST_XDIST_WORKER" in os.environ
    long_left_out = []
    kept = []
    for item in items:
        try:
            module = _module_path(item)
        except ValueError:  # a test outside this repository (e.g. a package's own tests)
            kept.append(item)
            continue
        if module in SERIAL_MODULES:
            item.add_marker(pytest.mark.serial)
            if in_xdist_worker:
                item.add_marker(pytest.mark.skip(reason=SERIAL_SKIP))
        if module in PY312_MODULES:
            item.add_marker(pytest.mark.py312)
        if _is_quick(module, getattr(item, "originalname", item.name)):
            item.add_marker(pytest.mark.quick)
        if item.get_closest_marker("long") and not config.getoption("--long"):
            long_left_out.append(item)
        else:
            kept.append(item)
    if long_left_out:
        config.hook.pytest_deselected(items=long_left_out)
        items[:] = kept
        config._trossen_long_left_out = len(long_left_out)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """With TROSSEN_LEROBOT_REQUIRED=1, a test skipped for want of LeRobot fails instead."""
    outcome = yield
    report = outcome.get_result()
    if not (report.skipped and os.environ.get("TROSSEN_LEROBOT_REQUIRED") == "1"):
        return
    if hasattr(report, "wasxfail") or not isinstance(report.longrepr, tuple):
        return
    reason = str(report.longrepr[2])
    if any(word in reason.lower() for word in LEROBOT_SKIP_WORDS):
        report.outcome = "failed"
        report.longrepr = (
            f"skipped for want of LeRobot while TROSSEN_LEROBOT_REQUIRED=1 "
            f"(tools/run_tests.sh sets it and installs the venv): {reason}"
        )


@pytest.fixture(scope="session", autouse=True)
def _network_guard_session() -> Iterator[NetworkGuard]:
    guard = NetworkGuard()
    with pytest.MonkeyPatch.context() as mp:
        guard.install(mp)
        yield guard


@pytest.fixture(autouse=True)
def network_guard(_network_guard_session: NetworkGuard) -> Iterator[NetworkGuard]:
    """The session's guard; fails the test if it blocked anything the test did not expect
    (a test that provokes a block on purpose clears ``guard.blocked``)."""
    guard = _network_guard_session
    guard.blocked.clear()
    yield guard
    if guard.blocked:
        attempts = "; ".join(guard.blocked)
        guard.blocked.clear()
        pytest.fail(f"the test tried to reach the network: {attempts}", pytrace=False)


# --- every episode recorded by the suite must replay on the real arm at its own rate -----
RECORDED_EPISODES_CHECKED: list[str] = []


@pytest.fixture(scope="session", autouse=True)
def _recorded_episodes_replay_at_50_fps(tmp_path_factory: pytest.TempPathFactory) -> Iterator:
    """At the end of the session, every episode file the recorder wrote anywhere under the
    session's temporary folders (including those of CLI subprocesses) passes the real-replay
    validator at 50 fps, as ``replay_episode_real.py --fps 50 --dry_run`` runs it, and says
    so in its ``real_replay_checked`` attribute."""
    yield
    import h5py

    from trossen_arm_mujoco.real.validate import TrajectoryError, validate_actions

    failures = []
    for path in sorted(tmp_path_factory.getbasetemp().rglob("episode_*.hdf5")):
        try:
            with h5py.File(path, "r") as f:
                if "real_replay_checked" not in f.attrs:
                    continue  # not written by the recorder (hand-made test files)
                checked, actions = bool(f.attrs["real_replay_checked"]), f["action"][()]
                layout = f.attrs.get("layout", "vendor16")
        except OSError:
            continue  # a deliberately corrupt file
        if layout == "mobileai":  # the Mobile AI's: the arms' 14 values, then the base's 2
            from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT

            actions = KIT14_LAYOUT.to_vendor(actions[:, :14])
        elif layout == "widowxai":  # a single arm's 7 values: checked as one arm of the kit
            from trossen_arm_mujoco.collect.single_arm import arm_to_vendor16

            actions = arm_to_vendor16(actions)
        try:
            validate_actions(actions, 50.0)
        except TrajectoryError as exc:
            failures.append(f"{path}: {exc}")
            continue
        if not checked:
            failures.append(f"{path}: real_replay_checked is False")
        RECORDED_EPISODES_CHECKED.append(str(path))
    if failures:
        pytest.fail("recorded episodes fail the real replay at 50 fps: " + "; ".join(failures))


def pytest_terminal_summary(terminalreporter) -> None:
    if RECORDED_EPISODES_CHECKED:
        terminalreporter.write_line(
            f"real-replay check: {len(RECORDED_EPISODES_CHECKED)} recorded episode(s) pass "
            "the validator at 50 fps"
        )
    left_out = getattr(terminalreporter.config, "_trossen_long_left_out", 0)
    if left_out:
        terminalreporter.write_line(
            f"{left_out} test(s) marked long left out: pytest --long runs them "
            "(bash tools/run_tests.sh runs them, as CI does)"
        )


# --- a MuJoCo Menagerie checkout made of tiny generated meshes -----------------------------
def write_fake_menagerie(root, layout: str = "new"):
    """Write ``root/trossen_wxai`` laid out like a Menagerie checkout, with a 2 cm box OBJ
    for every arm mesh (``layout`` "new": meshes/wxai + meshes/d405; "old": all in
    meshes/). Returns ``root``."""
    from trossen_arm_mujoco.sim.looks import MENAGERIE_MESHES

    corners = [(x, y, z) for x in (0, 0.02) for y in (-0.01, 0.01) for z in (0, 0.02)]
    faces = (
        (1, 2, 4),
        (1, 4, 3),
        (5, 7, 8),
        (5, 8, 6),
        (1, 5, 6),
        (1, 6, 2),
        (3, 4, 8),
        (3, 8, 7),
        (1, 3, 7),
        (1, 7, 5),
        (2, 6, 8),
        (2, 8, 4),
    )
    text = "".join(f"v {x} {y} {z}\n" for x, y, z in corners)
    text += "".join(f"f {a} {b} {c}\n" for a, b, c in faces)
    for parts in MENAGERIE_MESHES.values():
        for stem, _pos in parts:
            sub = "" if layout == "old" else ("d405" if "d405" in stem else "wxai")
            path = root / "trossen_wxai" / "assets" / "meshes" / sub / f"{stem}.obj"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
    return root


@pytest.fixture
def make_fake_menagerie():
    """``make_fake_menagerie(root, layout="new")``: see ``write_fake_menagerie``."""
    return write_fake_menagerie


@pytest.fixture
def fake_menagerie(tmp_path, monkeypatch):
    """A fake Menagerie checkout, named by TROSSEN_MENAGERIE_DIR for the test."""
    root = write_fake_menagerie(tmp_path / "mujoco_menagerie")
    monkeypatch.setenv("TROSSEN_MENAGERIE_DIR", str(root))
    return root


# -- output folders that refuse writes (read-only, full, immutable), for the error tests ---
@contextmanager
def tmpfs(path: Path, size: str = "64k", read_only: bool = False, folders: tuple = ()):
    """A tiny tmpfs mounted at ``path`` (a full disk after ``size``), or a read-only one
    holding ``folders``; skips when this process cannot mount (not root)."""
    path.mkdir(parents=True, exist_ok=True)
    proc = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
        capture_output=True,
        text=True,
    )
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs (needs root): {proc.stderr.strip()}")
    try:
        for name in folders:
            (path / name).mkdir()
        if read_only:
            subprocess.run(["mount", "-o", "remount,ro", str(path)], check=True)
        yield path
    finally:
        if subprocess.run(["umount", str(path)]).returncode != 0:
            subprocess.run(["umount", "-l", str(path)])


@contextmanager
def immutable(path: Path):
    """``path`` (a folder) with the immutable attribute: nothing, root included, may create
    files in it; skips where ``chattr +i`` is unavailable."""
    path.mkdir(parents=True, exist_ok=True)
    proc = subprocess.run(["chattr", "+i", str(path)], capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot set the immutable attribute: {proc.stderr.strip() or 'no chattr'}")
    try:
        yield path
    finally:
        subprocess.run(["chattr", "-i", str(path)], check=True)


@pytest.fixture
def fs_faults():
    """``fs_faults.tmpfs(path, size, read_only, folders)`` and ``fs_faults.immutable(path)``:
    context managers giving folders that refuse writes (they skip where root cannot make
    them)."""
    import types

    return types.SimpleNamespace(tmpfs=tmpfs, immutable=immutable)


# -- a private X display for live-viewer tests ---------------------------------------------
def xwd_rgb(data: bytes):
    """The pixels of an XWD image (``xwd``'s output: ZPixmap, 24 or 32 bits per pixel) as an
    (H, W, 3) uint8 RGB array; ValueError if ``data`` is not one."""
    import numpy as np

    if len(data) < 100:
        raise ValueError(f"{len(data)} bytes, shorter than an XWD header")
    head = [int(v) for v in np.frombuffer(data[:100], dtype=">u4")]
    header_size, pixmap_format, width, height = head[0], head[2], head[4], head[5]
    byte_order, bits_per_pixel, bytes_per_line = head[7], head[11], head[12]
    if pixmap_format != 2 or bits_per_pixel not in (24, 32):
        raise ValueError(f"format {pixmap_format}, {bits_per_pixel} bits per pixel")
    offset = header_size + 12 * head[19]  # after the window name and the colour entries
    if len(data) < offset + height * bytes_per_line:
        raise ValueError("truncated pixel data")
    rows = np.frombuffer(data, dtype=np.uint8, count=height * bytes_per_line, offset=offset)
    step = bits_per_pixel // 8
    pixels = rows.reshape(height, bytes_per_line)[:, : width * step].reshape(height, width, step)
    weights = 256 ** np.arange(step, dtype=np.uint64)  # least significant byte first
    values = (pixels.astype(np.uint64) * (weights[::-1] if byte_order == 1 else weights)).sum(-1)
    channels = []
    for mask in head[14:17]:  # red, green, blue masks
        shift = (mask & -mask).bit_length() - 1
        channels.append((values & np.uint64(mask)) >> np.uint64(shift))
    return np.stack(channels, axis=-1).astype(np.uint8)


class XScreen:
    """An Xvfb display of its own (``display``, e.g. ":121"); ``colours(path)`` takes a
    screenshot of its root window into ``path`` and returns how many colours it has (a
    blank screen has one, a rendered scene hundreds)."""

    def __init__(self, tmp_path: Path) -> None:
        import shutil
        import time

        if not (shutil.which("Xvfb") and shutil.which("xwd")):
            pytest.skip("Xvfb and xwd needed (apt-get install xvfb x11-apps)")
        free = [
            n
            for n in range(120, 160)
            if not Path(f"/tmp/.X11-unix/X{n}").exists() and not Path(f"/tmp/.X{n}-lock").exists()
        ]
        if not free:
            pytest.skip("no free X display number")
        self.tries: list[str] = []  # each screenshot's outcome, for report()
        self._log = tmp_path / "xvfb.log"
        # a test on another pytest-xdist worker may take the same free number at the same
        # moment: Xvfb then exits ("server already active") and the next number is tried
        for number in free[:5]:
            self.display = f":{number}"
            with open(self._log, "wb") as log:
                self._proc = subprocess.Popen(
                    ["Xvfb", self.display, "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                    stdout=log,
                    stderr=log,
                )
            deadline = time.monotonic() + 15
            while not Path(f"/tmp/.X11-unix/X{number}").exists():
                if self._proc.poll() is not None or time.monotonic() > deadline:
                    break
                time.sleep(0.1)
            else:
                return
            if self._proc.poll() is None:  # still starting after 15 s: not a lost race
                break
        self.close()
        pytest.fail(f"Xvfb did not start: {self._log.read_text()[-300:]}")

    @staticmethod
    def colours_of(rgb):
        """The distinct colours of an (H, W, 3) uint8 image, packed one integer each (a 1-D sort
        of about 60 ms at 1280x1024, where np.unique over rows takes seconds holding the GIL)."""
        import numpy as np

        img = rgb.astype(np.uint32)
        return np.unique((img[..., 0] << 16) | (img[..., 1] << 8) | img[..., 2])

    def screenshot(self, path: Path, timeout: float = 20.0):
        """The root window as an (H, W, 3) uint8 RGB array, read with ``xwd`` into ``path``
        (one request, where ImageMagick's ``import`` grabs the whole X server while it
        reads); None when none could be taken (why: ``report()``)."""
        import time

        path.unlink(missing_ok=True)
        start = time.monotonic()
        try:
            done = subprocess.run(
                ["xwd", "-root", "-silent", "-display", self.display, "-out", str(path)],
                capture_output=True,
                text=True,
                timeout=timeout,
            )
        except subprocess.TimeoutExpired:  # a busy X server: no screenshot this time
            self.tries.append(f"timed out after {timeout:g} s")
            return None
        if done.returncode != 0 or not path.exists():
            self.tries.append(f"xwd exit {done.returncode}: {done.stderr.strip()[-200:]!r}")
            return None
        try:
            rgb = xwd_rgb(path.read_bytes())
        except ValueError as exc:
            self.tries.append(f"unreadable screenshot: {exc}")
            return None
        self.tries.append(
            f"{len(self.colours_of(rgb))} colours in {time.monotonic() - start:.1f} s"
        )
        return rgb

    def colours(self, path: Path, timeout: float = 20.0) -> int:
        """How many colours a screenshot (``screenshot``) has: a blank screen has one, a
        rendered scene hundreds; 0 when none could be taken."""
        rgb = self.screenshot(path, timeout)
        return 0 if rgb is None else len(self.colours_of(rgb))

    @staticmethod
    def threads_state(pid: int) -> str:
        """Each thread of process ``pid`` as name:state:kernel wait channel:user+system CPU
        ticks (from /proc; for failure messages of tests that wait on another process)."""
        out = []
        for task in sorted(Path(f"/proc/{pid}/task").glob("*")):
            try:
                fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
                wchan = (task / "wchan").read_text().strip() or "-"
                name = (task / "comm").read_text().strip()
            except OSError:
                continue
            out.append(f"{name}:{fields[0]}:{wchan}:{fields[11]}+{fields[12]}")
        return " ".join(out) or "no /proc entry"

    def report(self) -> str:
        """The last screenshots' outcomes and the X server's state, for a failure message."""
        state = (
            f"running ({self.threads_state(self._proc.pid)})"
            if self._proc.poll() is None
            else f"exited {self._proc.returncode}"
        )
        log = self._log.read_text(errors="replace").strip()[-300:] if self._log.exists() else ""
        return (
            f"{len(self.tries)} screenshot(s), last: {'; '.join(self.tries[-4:])}; "
            f"Xvfb {state}; its log: {log!r}"
        )

    def close(self) -> None:
        self._proc.terminate()
        self._proc.wait(timeout=10)


@pytest.fixture
def xscreen(tmp_path: Path) -> Iterator[XScreen]:
    """A private Xvfb display (``XScreen``) for the test; skips without Xvfb and ImageMagick."""
    screen = XScreen(tmp_path)
    try:
        yield screen
    finally:
        screen.close()
