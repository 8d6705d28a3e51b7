"""An rclpy executor on a background thread that a controller process can always shut down.

A controller (the demo, a test, a user's script) often spins its subscriptions on a thread while
its main thread publishes commands and waits for answers. Two rules keep such a process from
hanging (``benchmarks/spin_thread_hang/README.md`` has the hang they prevent):

- **Entities are destroyed by the thread that waits on them, between two waits.** rclpy does not
  destroy an entity another thread is using: ``Node.destroy_node`` called while the executor
  thread sits in its wait (with every handle of the node entered) only marks the entities, and
  the executor thread destroys them when it leaves the wait, inside a C++ call that holds the
  GIL. If that teardown blocks, the whole process is stuck: no other thread gets the GIL back,
  so neither a timeout nor Python's SIGINT handler can run. :meth:`Spinner.destroy` therefore
  hands the node to the spin thread, which removes and destroys it when no wait is under way,
  and returns only when that is done (or raises ``SpinnerError`` after ``timeout``).
- **Every wait is bounded.** The thread calls ``spin_once(timeout_sec=period)`` in a loop that
  checks a stop flag, never ``spin()``; :meth:`Spinner.close` sets the flag, wakes the executor,
  joins the thread with a timeout, and only then destroys what is left and shuts the context
  down. A thread that does not stop in time is reported (``SpinnerError``), never waited on for
  ever.

The spinner owns its own :class:`rclpy.context.Context` (one ROS domain), so several can live
in one process, and it installs no signal handlers: SIGINT stays the process's own.
"""
from __future__ import annotations

import queue
import threading
from typing import Any, Callable

__all__ = ["Spinner", "SpinnerError"]


class SpinnerError(RuntimeError):
    """The spin thread did not do what was asked within the timeout."""


class Spinner:
    """One rclpy context in ``domain_id``, a single-threaded executor and the thread spinning it.

    Args:
        domain_id: the ROS domain (None: ``ROS_DOMAIN_ID``).
        name: the thread's name (shown by ``py-spy`` and in errors).
        period: the longest single wait of the executor, s; bounds how late the thread sees a
            stop request or a node to destroy.
        timeout: how long :meth:`destroy` and :meth:`close` wait for the spin thread, s.
    """

    def __init__(self, domain_id: int | None = None, *, name: str = "ros-spin",
                 period: float = 0.05, timeout: float = 10.0) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.signals import SignalHandlerOptions

        self.period, self.timeout = period, timeout
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id,
                   signal_handler_options=SignalHandlerOptions.NO)
        self.executor = SingleThreadedExecutor(context=self.context)
        self._chores: queue.SimpleQueue[tuple[Callable[[], None], threading.Event]] = \
            queue.SimpleQueue()
        self._stop = threading.Event()
        self._closed = False
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, name=name, daemon=True)
        self.thread.start()

    # -- the spin thread ---------------------------------------------------------------------

    def _run(self) -> None:
        try:
            while not self._stop.is_set() and self.context.ok():
                self.executor.spin_once(timeout_sec=self.period)
                self._do_chores()
        except Exception as e:  # noqa: BLE001  (the context shut down under us, or a callback)
            if self.context.ok() and not self._stop.is_set():
                self.error = e
        finally:
            self._do_chores()

    def _do_chores(self) -> None:
        while True:
            try:
                chore, done = self._chores.get_nowait()
            except queue.Empty:
                return
            try:
                chore()
            finally:
                done.set()

    # -- any thread --------------------------------------------------------------------------

    def node(self, name: str, **kwargs: Any) -> Any:
        """A new node in this spinner's context, spun from now on."""
        from rclpy.node import Node

        n = Node(name, context=self.context, **kwargs)
        self.executor.add_node(n)
        return n

    def add(self, node: Any) -> Any:
        """Spin ``node`` (made with ``context=spinner.context``) from now on; returns it."""
        self.executor.add_node(node)
        return node

    def destroy(self, node: Any) -> None:
        """Remove and destroy ``node`` on the spin thread; returns when it is done."""
        if threading.current_thread() is self.thread or not self.thread.is_alive():
            self._remove_and_destroy(node)
            return
        done = threading.Event()
        self._chores.put((lambda: self._remove_and_destroy(node), done))
        self.executor.wake()
        if not done.wait(self.timeout):
            raise SpinnerError(f"{self.thread.name}: node {node.get_name()!r} was not destroyed "
                               f"within {self.timeout:g} s")

    def _remove_and_destroy(self, node: Any) -> None:
        self.executor.remove_node(node)
        node.destroy_node()

    def close(self) -> None:
        """Stop the thread, destroy the nodes still spun, shut the context down. Idempotent."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        try:
            self.executor.wake()
        except Exception:  # noqa: BLE001  (already shut down)
            pass
        self.thread.join(self.timeout)
        stuck = self.thread.is_alive()
        if not stuck:   # nothing waits on the entities any more: safe to destroy them here
            for n in list(self.executor.get_nodes()):
                self._remove_and_destroy(n)
            self.executor.shutdown(timeout_sec=self.timeout)
        import rclpy

        rclpy.try_shutdown(context=self.context)
        if stuck:
            raise SpinnerError(f"{self.thread.name} did not stop within {self.timeout:g} s")

    def __enter__(self) -> "Spinner":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
