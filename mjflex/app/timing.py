"""Where a command's wall time went: named phases, timed one after the other, and the start-up before them."""

import os
import time
from contextlib import contextmanager


def process_start():
    """``time.perf_counter()`` reading at this process's start (Linux: from ``/proc``), or None where unknown.

    The kernel records the start in clock ticks since boot (10 ms on most systems), so the value
    is good to about 10 ms.
    """
    try:
        with open("/proc/self/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()  # the command name may hold spaces; fields from 3 on
        started = int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22: start time after boot [ticks]
        age = time.clock_gettime(time.CLOCK_BOOTTIME) - started
    except (OSError, ValueError, IndexError, AttributeError):  # not Linux, or /proc not mounted
        return None
    return time.perf_counter() - age if age >= 0 else None


class Stopwatch:
    """Wall time of consecutive phases of a command, in seconds, in the order they first ran.

    ``start`` is the ``time.perf_counter()`` reading the total counts from (default: now). Use
    ``with clock.phase("name"):`` around each part, or :meth:`add` for a time measured
    elsewhere; a phase entered twice adds up. The time between phases is not hidden: it is
    reported as unaccounted. Beside the wall time, each phase gets the CPU time it used
    (``time.process_time``: every thread of this process; :meth:`add` may give it, or that of
    a child process): on a machine shared with other work, the CPU time is the steadier measure.
    """

    def __init__(self, start=None):
        self.start = time.perf_counter() if start is None else start
        self.phases, self.cpu = {}, {}

    @contextmanager
    def phase(self, name):
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.add(name, time.perf_counter() - t0, time.process_time() - c0)

    def add(self, name, seconds, cpu=None):
        self.phases[name] = self.phases.get(name, 0.0) + float(seconds)
        if cpu is not None:
            self.cpu[name] = self.cpu.get(name, 0.0) + float(cpu)

    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def breakdown(self) -> dict:
        """``{"total_s", "phases_s": {name: seconds}, "unaccounted_s", "phases_cpu_s"}`` at this moment."""
        total = self.elapsed()
        return {
            "total_s": total,
            "phases_s": dict(self.phases),
            "unaccounted_s": total - sum(self.phases.values()),
            "phases_cpu_s": dict(self.cpu),
        }

    def text(self, breakdown=None) -> str:
        """One line: each phase's seconds and share of the total, the unaccounted rest, the total.

        ``breakdown``: one taken before by :meth:`breakdown` (default: now).
        """
        b = breakdown or self.breakdown()
        total = max(b["total_s"], 1e-12)
        parts = [f"{name} {s:.2f} s ({s / total:.0%})" for name, s in b["phases_s"].items()]
        parts.append(f"other {b['unaccounted_s']:.2f} s")
        return f"where the time went: {', '.join(parts)}; total {b['total_s']:.2f} s"
