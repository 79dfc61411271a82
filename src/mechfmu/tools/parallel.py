"""The one local parallel runner: worker processes of this machine (concurrent.futures),
used by ``mechfmu sweep`` (points, with retries of points whose worker died) and
``mechfmu study`` (points in order)."""

from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import get_context
import os
import signal
import time
from typing import Any


def _start_worker(initializer: Callable[..., None] | None, initargs: tuple) -> None:
    """First thing in a worker process: SIGTERM back to its default, then ``initializer``.

    A forked worker inherits the parent's handlers, and the sweep's parent runs under an
    InterruptGuard whose SIGTERM handler only takes note. A broken executor terminates its
    surviving workers with SIGTERM and joins them; with the guard's handler they would live
    on, and the join (CPython 3.12.1's, holding the executor's lock) would never return.
    """
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if initializer is not None:
        initializer(*initargs)


def os_threads() -> int | None:
    """How many threads this process has, as the OS counts them (None: no /proc)."""
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return None


def settle_threads(count: int | None, timeout: float = 1.0) -> None:
    """Wait, up to ``timeout`` s, until this process is back to ``count`` OS threads.

    Joining a Python thread returns just before its OS thread ends; a fork in that instant
    still counts it (and CPython 3.12+ warns that the process is multi-threaded)."""
    deadline = time.monotonic() + timeout
    while count is not None and (os_threads() or 0) > count and time.monotonic() < deadline:
        time.sleep(0.001)


MAX_WORKERS_PER_CORE = 4  # local worker processes per core a command may ask for


def workers_problem(option: str, workers: int) -> str | None:
    """The one line refusing ``workers`` local worker processes (``option`` names where they
    were asked for), or None: more than MAX_WORKERS_PER_CORE per core of this machine would
    only share the cores, each process loading the FMUs (a pool forks them all at once:
    --jobs 100000 forked until the machine stalled)."""
    cores = os.cpu_count() or 1
    if workers <= MAX_WORKERS_PER_CORE * cores:
        return None
    return (
        f"{option} = {workers} is more than {MAX_WORKERS_PER_CORE} local worker processes per "
        f"core (this machine has {cores}: at most {MAX_WORKERS_PER_CORE * cores}); each is a "
        f"process that loads the FMUs, and more than the cores only share them: lower {option}"
    )


class LocalPool:
    """Worker processes on this machine running ``task``, reading the FMUs in place.

    Each worker runs ``initializer(*initargs)`` first; ``context`` is the multiprocessing
    start method (None: the platform's default; "spawn": a fresh interpreter with no FMU
    loaded). A worker process that dies (killed, out of memory, a crash in an FMU) breaks
    the whole executor: every point not finished is lost with BrokenProcessPool.
    ``restart`` replaces the executor; the sweep resubmits the lost points. The executor
    starts with the first point after construction, ``restart`` or ``idle``."""

    def __init__(
        self,
        jobs: int,
        task: Callable[..., Any],
        initializer: Callable[..., None] | None = None,
        initargs: tuple = (),
        context: str | None = None,
    ) -> None:
        self.workers, self.where = jobs, f"local, {jobs} process(es)"
        self.task, self.initializer, self.initargs, self.context = (
            task,
            initializer,
            initargs,
            context,
        )
        self.executor: ProcessPoolExecutor | None = None
        self.threads_before = os_threads()

    def _running(self) -> ProcessPoolExecutor:
        if self.executor is None:
            self.threads_before = os_threads()  # the executor's threads start now
            self.executor = ProcessPoolExecutor(
                max_workers=self.workers,
                initializer=_start_worker,
                initargs=(self.initializer, self.initargs),
                mp_context=get_context(self.context) if self.context else None,
            )
        return self.executor

    def ship(self, paths: Iterable[str]) -> None:
        """Local workers read the FMUs where they are: nothing to send."""
        return None

    def submit(self, *arguments: Any) -> Future:
        """``task(*arguments)`` on a worker."""
        return self._running().submit(self.task, *arguments)

    def map(self, items: Iterable[Any]) -> Iterator[Any]:
        """``task(item)`` of each item on the workers, in the items' order."""
        return self._running().map(self.task, items)

    @staticmethod
    def wait(futures: list[Future], timeout: float) -> set[Future]:
        """The futures among ``futures`` that are done, waiting up to ``timeout`` s for one."""
        return wait(futures, timeout=timeout, return_when=FIRST_COMPLETED).done

    @staticmethod
    def lost(error: BaseException | None) -> bool:
        """Whether a point failed because its worker process died (not because of itself)."""
        return isinstance(error, BrokenProcessPool)

    def idle(self) -> None:
        """Let the workers go (``close``) until the next ``submit``: while a point runs
        ``alone``, no other executor's thread is there when its worker is forked."""
        self.close()
        self.executor = None

    def restart(self) -> None:
        """A new executor in place of a broken one, from the next ``submit`` (the broken
        one's workers and thread gone first)."""
        self.idle()

    def alone(self) -> "LocalPool":
        """A pool of one new worker process, for a point on its last attempt: if that worker
        dies too, the point is the cause, not a neighbour."""
        return LocalPool(1, self.task, self.initializer, self.initargs, self.context)

    def close(self, interrupted: bool = False) -> None:
        """Shut the workers down: at once (``interrupted``: their points are abandoned) or
        after their points.

        Either way this returns once the workers and the executor's thread are gone: a thread
        still running when later workers are forked (the next sweep's, a restart's) may hold
        a lock at that instant, and the forked worker inherits it locked for good (CPython
        3.12+ warns of such forks)."""
        if self.executor is None:
            return
        if interrupted:
            for worker in list((getattr(self.executor, "_processes", None) or {}).values()):
                worker.terminate()
        self.executor.shutdown(wait=True, cancel_futures=interrupted)
        settle_threads(self.threads_before)
