"""Project exception types.

Every error the public API raises on bad input is a :class:`QsplanError`
(a :class:`ValueError`), with a message that says what was expected and what came.
"""

from __future__ import annotations


class QsplanError(ValueError):
    """Base class of every documented error of this project."""


class InputError(QsplanError):
    """An argument or file field has the wrong shape, type, sign or value."""


class FileFormatError(InputError):
    """A system or plan file is malformed (bad JSON, missing keys, wrong version)."""


class DegenerateError(QsplanError):
    """The configuration is degenerate for the requested operation (e.g. singular)."""


class GeometryWarning(UserWarning):
    """The input is usable but probably not what was meant (e.g. a weight written by hand
    without its moment about the origin); the message says what and how to fix it."""
