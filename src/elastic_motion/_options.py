"""One way to take an app's options: a frozen options object, changed by keyword overrides.

Every app takes one frozen dataclass of options (:class:`elastic_motion.warp.WarpOptions`,
:class:`elastic_motion.apps.loop.LoopOptions`, ...) and, for a notebook's convenience, keyword
overrides of its fields: ``em.loop(m, root="inplace")`` is ``em.loop(m, LoopOptions(root="inplace"))``.
:func:`with_overrides` is that rule, once: an unknown keyword is an error naming it and the
fields there are; the options are validated by the dataclass itself (``__post_init__``).

:func:`choices` reads the allowed values of a ``Literal`` type, so that the command line and
the error messages list exactly what the options type accepts.
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar, get_args

from elastic_motion.errors import OptionError

__all__ = ["choices", "options_from_json", "with_overrides"]

T = TypeVar("T")


def with_overrides(
    cls: type[T], options: T | None, overrides: dict[str, Any], *, argument: str = "options"
) -> T:
    """``options`` (default ``cls()``) with the fields in ``overrides`` changed.

    Parameters
    ----------
    cls : dataclass type
        The options type (frozen; validates itself in ``__post_init__``).
    options : cls instance or None
    overrides : dict
        Field name -> value; validated again by ``cls``.
    argument : str
        The name of the options argument, for the error.

    Raises
    ------
    OptionError
        ``options`` is not a ``cls``; a key of ``overrides`` is not a field of ``cls``.
    """
    base = cls() if options is None else options
    if not isinstance(base, cls):
        raise OptionError(argument, f"expected a {cls.__name__}; got {type(base).__name__}")
    if not overrides:
        return base
    fields = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(overrides) - fields)
    if unknown:
        raise OptionError(
            unknown[0],
            f"unknown option{'s' if len(unknown) > 1 else ''} {unknown} of {cls.__name__}; "
            f"expected some of {sorted(fields)}",
        )
    return dataclasses.replace(base, **overrides)  # type: ignore[type-var]


def options_from_json(cls: type[T], data: dict[str, Any], *, argument: str) -> T:
    """A ``cls`` from the dict of its fields (its ``to_json``); unknown keys are an error naming them."""
    fields = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    bad = sorted(set(data) - fields)
    if bad:
        raise OptionError(argument, f"unknown fields {bad}; expected some of {sorted(fields)}")
    return cls(**data)


def choices(literal: Any) -> tuple[str, ...]:
    """The values of a ``Literal[...]`` type, in order (what a CLI's ``choices=`` lists)."""
    values = get_args(literal)
    if not values or not all(isinstance(v, str) for v in values):
        raise TypeError(f"expected a Literal of strings; got {literal!r}")
    return tuple(values)
