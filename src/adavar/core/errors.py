"""Exceptions for user mistakes (the CLI turns them into one-line messages and exit code 2)."""

from __future__ import annotations

__all__ = ["AdavarInputError"]


class AdavarInputError(ValueError):
    """Bad input from the user: the message names the problem and the way out."""
