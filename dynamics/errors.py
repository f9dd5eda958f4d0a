"""Errors raised by the library.

Every error a caller can provoke with bad input is a ``ValueError`` subclass, so that
``except ValueError`` catches them all, and its message names what was wrong and what was expected.
"""

import difflib


class DynamicsError(ValueError):
    """Base class of every input error raised by :mod:`dynamics`."""


class URDFError(DynamicsError):
    """The URDF could not be turned into a model; the message names the link or joint at fault."""


class InputError(DynamicsError):
    """An argument has the wrong shape, type or value; the message names the argument and what was expected."""


class DeadlineExceeded(TimeoutError):
    """A batched call ran past the deadline set with :func:`dynamics.parallel.deadline` (not an input error).

    ``done`` counts the states finished by the thread that noticed, ``total`` the batch size."""

    def __init__(self, message, *, done=0, total=0):
        super().__init__(message)
        self.done, self.total = done, total


class SimulationWarning(UserWarning):
    """A simulation finished but its report has warnings (``report["warnings"]``: an inaccurate error estimate,
    a run that stopped early, ...): each is also emitted with this category, so that
    ``warnings.simplefilter("error", dynamics.SimulationWarning)`` turns them into errors and "ignore" hides them."""


def closest(name, names, what):
    """An InputError for an unknown ``name`` that lists the closest of ``names``."""
    near = difflib.get_close_matches(str(name), [str(n) for n in names], n=5, cutoff=0.4)
    hint = f"; closest: {near}" if near else f"; there are {len(names)}: {list(names)[:12]}"
    return InputError(f"{what}: no {'frame' if what == 'frame' else 'joint'} named {name!r}{hint}")
