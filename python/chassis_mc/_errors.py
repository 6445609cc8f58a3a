"""The exceptions chassis_mc raises (the Rust side builds them by these classes)."""

from __future__ import annotations

from typing import Optional


class ChassisMcError(Exception):
    """Base class of chassis_mc's own errors."""


class StudyError(ChassisMcError, ValueError):
    """A study (or fit file) that cannot be run: where and why.

    Attributes:
        file: the file it was read from, ``<string>`` for TOML text, ``<dict>`` for a dict,
            or ``command line`` for an override such as ``realisations``.
        key: the dotted key at fault, e.g. ``vehicle.mass`` or ``terrain.scales[2]``, or None.
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


class RunError(ChassisMcError, RuntimeError):
    """A failure while running (writing output, a damaged file, threads), or an output
    directory that cannot be used as it is (``bad_input`` true: the command line exits 2)."""

    def __init__(self, message: str, bad_input: bool = False) -> None:
        super().__init__(message)
        self.bad_input = bad_input
