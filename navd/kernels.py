"""numba's cache of the daemon's kernels, filled in a process of its own.

Compiling the kernels (on the first start, and the first after an upgrade of navd or numba)
leaves LLVM holding memory the process never hands back (docs/performance.md, "Memory", has
the figures). So a daemon that finds the
cache cold has a child process compile them and exit, which frees all of it, and then loads
them from the cache like any later start. ``navd kernels`` fills the cache ahead of time (the
set-up and ``deploy/install.sh`` run it), so a robot's first start is no slower than the next.

Which cache: numba's, where ``cache=True`` kernels keep their machine code (``__pycache__``
beside the sources, or ``NUMBA_CACHE_DIR``); the child inherits the environment, so it fills
the very cache the daemon reads.
"""

from __future__ import annotations

import importlib
import pickle
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

import numba
from numba.core.dispatcher import Dispatcher

from navd.config import NavdConfig
from navd.errors import NavdError
from navd.logs import get_logger

__all__ = ["KERNEL_MODULES", "KernelCache", "KernelCacheError", "cold_kernels", "warm_up_all"]

_log = get_logger("kernels")

# Every module of the daemon that defines numba kernels (a test checks that no other does).
KERNEL_MODULES = (
    "navd.geometry._angle_kernels",
    "navd.geometry._footprint_kernels",
    "navd.geometry._scan_kernels",
    "navd.estimation._madgwick_kernels",
    "navd.estimation._ukf_kernels",
    "navd.slam._grid_kernels",
    "navd.slam._odometry_kernels",
    "navd.planning._astar_kernels",
    "navd.planning._bitgrid_kernels",
    "navd.planning._bucket_kernels",
    "navd.planning._costmap_kernels",
    "navd.planning._distance_kernels",
    "navd.planning._dwa_kernels",
    "navd.planning._guard_kernels",
)

COMPILE_TIMEOUT_S = 900.0  # a cold compile takes about a minute here, a few on the board


def warm_up_all() -> None:
    """Compile (or load from the cache) every kernel navd can run: estimation, SLAM, planning
    and the collision guard, through each room's own warm-up, and what a replay adds (the
    fine refinement), so one child fills the cache for the daemon and ``navd replay``."""
    # Imported here: a process that only checks the cache does not load the rooms' kernels.
    from navd.estimation import warm_up as warm_estimation  # noqa: PLC0415
    from navd.offline import warm_up as warm_replay  # noqa: PLC0415
    from navd.planning import warm_up as warm_planning  # noqa: PLC0415

    warm_estimation(NavdConfig().estimation)
    warm_planning()
    warm_replay()  # the daemon's SLAM kernels, then the fine refinement's


def _dispatchers() -> Iterator[tuple[str, Dispatcher]]:
    """Each kernel of ``KERNEL_MODULES`` that numba compiles on its own, with its dotted
    name (one inlined into its callers has no machine code of its own)."""
    for module_name in KERNEL_MODULES:
        module = importlib.import_module(module_name)
        for name, value in vars(module).items():
            if (
                isinstance(value, Dispatcher)
                and value.py_func.__module__ == module_name
                and value.targetoptions.get("inline") != "always"
            ):
                yield f"{module_name}.{name}", value


class KernelCacheError(NavdError):
    """numba's cache index cannot be read with this numba (its internals differ from the
    ones navd was written for): whether a kernel is cached is unknown."""


def _is_cached(dispatcher: Dispatcher) -> bool:
    """Whether numba's cache holds machine code of this kernel's present source for this
    machine (any signature): what its first call would load instead of compiling.

    Reads numba's index through its cache object. An index that cannot be read (a file cut
    short) counts as cold: numba compiles and writes it again.

    Raises:
        KernelCacheError: this numba keeps its cache otherwise.
    """
    cache: Any = getattr(dispatcher, "_cache", None)
    try:
        cache_file, index_key = cache._cache_file, cache._index_key
        target: Any = dispatcher.targetctx
        wanted = tuple(index_key(None, target.codegen())[1:])
    except (AttributeError, TypeError) as err:
        raise KernelCacheError(
            f"numba {numba.__version__} keeps its cache in a way navd cannot read ({err}); "
            "the kernels compile in the daemon itself"
        ) from err
    try:
        index = cache_file._load_index()
    except (OSError, EOFError, ValueError, pickle.UnpicklingError, AttributeError):
        return False
    return any(tuple(key[1:]) == wanted for key in index)


def cold_kernels() -> list[str]:
    """The daemon's kernels that numba's cache holds nothing for (their dotted names).

    Raises:
        KernelCacheError: whether they are cached cannot be known with this numba.
    """
    return [name for name, dispatcher in _dispatchers() if not _is_cached(dispatcher)]


class KernelCache:
    """Makes sure, once per process, that the kernels are in the cache before any warm-up
    loads them: a cold cache is filled by a child process (``navd kernels``).

    ``prepare`` may be called from several warm-up threads at once; the first does the work
    and the others wait for it. It never raises: if the child fails (or the cache cannot be
    read), the warm-ups compile in this process as before (more memory, same kernels) and
    why is logged.
    """

    def __init__(self, command: tuple[str, ...] | None = None) -> None:
        self._command = command or (sys.executable, "-m", "navd", "kernels")
        self._lock = threading.Lock()  # one prepare at a time
        self._spawn = threading.Lock()  # starting the child and stopping it
        self._done = False
        self._child: subprocess.Popen[str] | None = None
        self._stopped = False

    def prepare(self, *, every_signature: bool = False) -> None:
        """Fill the cache if it is cold (blocks: call it from a warm-up thread).

        With ``every_signature`` the child runs even when every kernel has something in the
        cache: the index tells whether a kernel was compiled, not for which argument types,
        and a cache filled by other programs (a test run) may lack the ones the warm-ups
        call. The child then only loads what is there and compiles the rest (a few seconds).
        """
        with self._lock:
            if self._done:
                return
            try:
                self._fill(every_signature)
            except Exception as err:  # the warm-ups go on whatever happened here
                _log.warning("kernels_prepare_failed", error=str(err), fallback="in process")
            finally:
                self._done = True

    def stop(self) -> None:
        """End a compile still running (the daemon is stopping); later calls of ``prepare``
        compile nothing."""
        with self._spawn:
            self._stopped = True
            child = self._child
        if child is not None and child.poll() is None:
            child.kill()
            child.wait()

    def _fill(self, every_signature: bool) -> None:
        try:
            cold = cold_kernels()
        except KernelCacheError as err:
            _log.warning("kernels_cache_unreadable", reason=str(err))
            return
        if not cold and not every_signature:
            return
        _log.info("kernels_compiling", cold=len(cold), first=cold[0] if cold else "")
        started = time.monotonic()
        with self._spawn:
            if self._stopped:
                return
            try:
                self._child = child = subprocess.Popen(
                    self._command,
                    stdin=subprocess.DEVNULL,
                    stdout=subprocess.PIPE,
                    stderr=subprocess.STDOUT,
                    text=True,
                )
            except OSError as err:
                _log.warning("kernels_compile_failed", reason=str(err), fallback="in process")
                return
        try:
            output, _ = child.communicate(timeout=COMPILE_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
            _log.warning(
                "kernels_compile_failed",
                reason=f"still compiling after {COMPILE_TIMEOUT_S:g} s",
                fallback="in process",
            )
            return
        if self._stopped:  # the daemon is stopping: the cache stays as the child left it
            return
        if child.returncode != 0:
            _log.warning(
                "kernels_compile_failed",
                reason=f"exit code {child.returncode}",
                output=" | ".join(output.strip().splitlines()[-3:]),
                fallback="in process",
            )
            return
        _log.info("kernels_compiled", s=round(time.monotonic() - started, 1))
