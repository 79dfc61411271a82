"""The one local parallel runner: worker processes of this machine (concurrent.futures),
used by ``mechfmu sweep`` (points, with retries of points whose worker died) and
``mechfmu study`` (points in order)."""

from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import get_context
import signal
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


class LocalPool:
    """Worker processes on this machine running ``task``, reading the FMUs in place.

    Each worker runs ``initializer(*initargs)`` first; ``context`` is the multiprocessing
    start method (None: the platform's default; "spawn": a fresh interpreter with no FMU
    loaded). A worker process that dies (killed, out of memory, a crash in an FMU) breaks
    the whole executor: every point not finished is lost with BrokenProcessPool.
    ``restart`` replaces the executor; the sweep resubmits the lost points."""

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
        self.executor = self._executor()

    def _executor(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            max_workers=self.workers,
            initializer=_start_worker,
            initargs=(self.initializer, self.initargs),
            mp_context=get_context(self.context) if self.context else None,
        )

    def ship(self, paths: Iterable[str]) -> None:
        """Local workers read the FMUs where they are: nothing to send."""
        return None

    def submit(self, *arguments: Any) -> Future:
        """``task(*arguments)`` on a worker."""
        return self.executor.submit(self.task, *arguments)

    def map(self, items: Iterable[Any]) -> Iterator[Any]:
        """``task(item)`` of each item on the workers, in the items' order."""
        return self.executor.map(self.task, items)

    @staticmethod
    def wait(futures: list[Future], timeout: float) -> set[Future]:
        """The futures among ``futures`` that are done, waiting up to ``timeout`` s for one."""
        return wait(futures, timeout=timeout, return_when=FIRST_COMPLETED).done

    @staticmethod
    def lost(error: BaseException | None) -> bool:
        """Whether a point failed because its worker process died (not because of itself)."""
        return isinstance(error, BrokenProcessPool)

    def restart(self) -> None:
        """A new executor in place of a broken one."""
        self.executor.shutdown(wait=False, cancel_futures=True)
        self.executor = self._executor()

    def alone(self) -> "LocalPool":
        """A pool of one new worker process, for a point on its last attempt: if that worker
        dies too, the point is the cause, not a neighbour."""
        return LocalPool(1, self.task, self.initializer, self.initargs, self.context)

    def close(self, interrupted: bool = False) -> None:
        """Shut the workers down: at once (``interrupted``) or after their points."""
        self.executor.shutdown(wait=not interrupted, cancel_futures=interrupted)
