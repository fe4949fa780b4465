"""``python -m mjflex``: see :mod:`mjflex.app.cli`."""

import atexit
import os
import sys
import threading

from .app.cli import main as _main


def main(argv=None):
    """The command line (:func:`mjflex.app.cli.main`); a command that finished ends the process at once.

    Python's teardown of the interpreter after a command (numba's and LLVM's finalizers, module
    by module) took about half a second after the demo. Once the command has returned, every
    file it wrote is closed; the output streams are flushed and the exit handlers (``atexit``)
    run as usual, then the process exits with status 0 without the teardown. Errors, and a
    command that leaves a thread running, take Python's normal exit.
    """
    _main(argv)
    if argv is not None or threading.active_count() > 1:
        return
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more can be shown
            pass
    atexit._run_exitfuncs()
    os._exit(0)


if __name__ == "__main__":
    main()
