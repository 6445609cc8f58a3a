"""The ``chassis-mc`` command the wheel installs: the same command line as the Rust binary."""

from __future__ import annotations

import signal
import sys

from . import _core


def main() -> None:
    """Run ``chassis-mc`` with this process's arguments and exit with its status."""
    # Ctrl-C ends the command at once, as it ends the Rust binary (a run's completed parts
    # stay and the next run resumes from them); Python's own handler would wait for it.
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    sys.exit(_core.main(["chassis-mc", *sys.argv[1:]]))


if __name__ == "__main__":
    main()
