"""argparse value types shared by every `gloverec` subcommand: numbers with a clear one-line error."""

from __future__ import annotations

import argparse


def number(kind=float, zero_ok: bool = False):
    """A type that parses ``kind`` and requires it positive (or, with ``zero_ok``, zero or more)."""
    word = "a whole number" if kind is int else "a number"

    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not {word}: {text!r}") from None
        if value < 0 or (value == 0 and not zero_ok) or value != value:
            raise argparse.ArgumentTypeError(f"must be {'zero or more' if zero_ok else 'positive'}: {text!r}")
        return value

    return parse


positive_int = number(int)
positive_float = number(float)
natural = number(int, zero_ok=True)
