"""argparse value types shared by every `gloverec` subcommand (and by the flags recorder/config.py generates):
numbers with their constraints and a clear one-line error."""

from __future__ import annotations

import argparse

import annotated_types as at


def number(kind=float, *constraints):
    """A type that parses ``kind`` and checks annotated_types constraints (Gt, Ge, Lt, Le)."""
    word = "a whole number" if kind is int else "a number"

    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not {word}: {text!r}") from None
        if value != value:
            raise argparse.ArgumentTypeError(f"not {word}: {text!r}")
        for c in constraints:
            if isinstance(c, at.Gt) and not value > c.gt:
                raise argparse.ArgumentTypeError(f"must be {'positive' if c.gt == 0 else f'above {c.gt}'}: {text!r}")
            if isinstance(c, at.Ge) and not value >= c.ge:
                raise argparse.ArgumentTypeError(
                    f"must be {'zero or more' if c.ge == 0 else f'{c.ge} or more'}: {text!r}"
                )
            if isinstance(c, at.Lt) and not value < c.lt:
                raise argparse.ArgumentTypeError(f"must be below {c.lt}: {text!r}")
            if isinstance(c, at.Le) and not value <= c.le:
                raise argparse.ArgumentTypeError(f"must be {c.le} or less: {text!r}")
        return value

    return parse


positive_int = number(int, at.Gt(0))
positive_float = number(float, at.Gt(0))
natural = number(int, at.Ge(0))
