"""The exceptions chassis_mc raises (the Rust side builds them by these classes).

Each pickles with its fields (``__reduce__``), so an error raised in a worker process
(``multiprocessing``, ``concurrent.futures``) reaches the parent as the same class with the
same ``file``, ``key``, ``line``, ``reason`` or ``bad_input``.
"""

from __future__ import annotations

from typing import Any, Optional, Tuple


class ChassisMcError(Exception):
    """Base class of chassis_mc's own errors."""


class StudyError(ChassisMcError, ValueError):
    """A study (or fit file) that cannot be run: where and why.

    Attributes:
        file: the file it was read from, ``<string>`` for TOML text, ``<dict>`` for a dict,
            ``<arguments>`` for an argument of the call such as ``realisations``, or ``the
            DataFrame given as log`` for a log table that cannot be converted.
        key: the dotted key at fault, e.g. ``vehicle.mass`` or ``terrain.scales[2]`` (for
            an argument, its name), or None.
        line: the 1-based line of the key in the file, or None (always None for a dict).
        reason: what is wrong, in words.
    """

    def __init__(
        self,
        message: str,
        file: str,
        key: Optional[str] = None,
        line: Optional[int] = None,
        reason: str = "",
    ) -> None:
        super().__init__(message)
        self.file = file
        self.key = key
        self.line = line
        self.reason = reason

    def __reduce__(self) -> Tuple[Any, ...]:
        # Exception's own reduction rebuilds from `args` (the message alone), which this
        # __init__ cannot take: rebuild from every field (and keep any other attribute).
        message = self.args[0] if self.args else ""
        return (
            type(self),
            (message, self.file, self.key, self.line, self.reason),
            self.__dict__,
        )


class RunError(ChassisMcError, RuntimeError):
    """A failure while running (writing output, a damaged file, threads), or an output
    directory that cannot be used as it is (``bad_input`` true: the command line exits 2)."""

    def __init__(self, message: str, bad_input: bool = False) -> None:
        super().__init__(message)
        self.bad_input = bad_input

    def __reduce__(self) -> Tuple[Any, ...]:
        message = self.args[0] if self.args else ""
        return (type(self), (message, self.bad_input), self.__dict__)
