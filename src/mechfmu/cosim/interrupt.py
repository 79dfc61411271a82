"""Ctrl-C (SIGINT) and SIGTERM during a run: noted by a handler, acted on between steps.

Python runs a signal handler in the main thread at the next bytecode, and an FMU built with
pythonfmu runs its Python code in the host's interpreter (fmpy's process), in that same
thread. Python's default SIGINT handler raises KeyboardInterrupt, which then lands inside the
FMU's code: pythonfmu turns it into fmi2Fatal and leaves the interpreter in a state that
crashes the host at its next call (signal 11). SIGTERM's default kills the process without
freeing anything. While an InterruptGuard is active its handlers only note the signal; the
master asks ``requested`` between steps and stops cleanly there.
"""

import signal
import threading
from types import TracebackType
from typing import Any, Literal

SIGNALS = (signal.SIGINT, signal.SIGTERM)


def exit_code(signum: Any) -> Any:
    """The shell's code for a command ended by ``signum``: 128 + number (130, 143)."""
    return 128 + int(signum)


def signal_name(signum: signal.Signals) -> str:
    """'SIGINT', 'SIGTERM', ..."""
    return signal.Signals(signum).name


class InterruptGuard:
    """A with-block during which SIGINT and SIGTERM are noted instead of acted on.

    ``signum`` is the first signal received (None: none). Whoever stops because of it calls
    ``take()``; a signal nobody took is delivered again, to the handler that was there
    before, when the block ends (so a Ctrl-C after the last step still ends a script the
    usual way). Handlers can only be installed in the main thread: elsewhere (a worker
    thread) the guard does nothing and ``signum`` stays None. A signal the process ignores
    (SIG_IGN, as under nohup) stays ignored.
    """

    def __init__(self) -> None:
        self.signum = None
        self.taken = False
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> "InterruptGuard":
        if threading.current_thread() is threading.main_thread():
            for signum in SIGNALS:
                if signal.getsignal(signum) is not signal.SIG_IGN:
                    self._previous[signum] = signal.signal(signum, self._note)
        return self

    def _note(self, signum: Any, frame: Any) -> None:
        if self.signum is None:
            self.signum = signum

    @property
    def requested(self) -> bool:
        """Whether a signal arrived and the work should stop at the next safe point."""
        return self.signum is not None

    def take(self) -> Any:
        """Acknowledge the signal (it has been acted on); returns its number."""
        self.taken = True
        return self.signum

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> Literal[False]:
        for signum, previous in self._previous.items():
            signal.signal(signum, signal.SIG_DFL if previous is None else previous)
        self._previous.clear()
        if self.signum is not None and not self.taken:
            self.taken = True
            signal.raise_signal(self.signum)
        return False
