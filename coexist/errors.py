"""One error hierarchy for the whole library.

Every failure that leaves :mod:`coexist` is a :class:`CoexistError` that names its cause and the
input that caused it; the command line turns :class:`SceneError` (bad input) into exit code 2 and
every other :class:`CoexistError` (a solver or physical failure) into exit code 1.
"""

from __future__ import annotations


class CoexistError(Exception):
    """Base class of every error raised by :mod:`coexist`."""


class SceneError(CoexistError, ValueError):
    """Bad input: a scene field, a command-line option or a function argument out of range.

    Parameters
    ----------
    message : str
        What is wrong and what would be right.
    field : str, optional
        The field or option that holds the bad value, e.g. ``"[chamber].volume"`` or ``"--jlim"``.
    """

    def __init__(self, message: str, field: str | None = None):
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}" if field else message)


class SolverError(CoexistError, RuntimeError):
    """A numerical solve did not converge or could not be verified; the message says why."""


class ModelRangeError(CoexistError):
    """The request lies outside the range where the membrane model holds.

    Raised for wrinkling (a tension turns negative), Gent locking, breakdown, or a voltage at
    which no pressurised equilibrium exists. ``reason`` is a short machine-readable tag; ``above_top`` is True
    where the thing asked for is known to lie above the scene's highest voltage (a transition that a ramp of the
    scene does not reach: the states go on past the top of its path).
    """

    def __init__(self, message: str, reason: str = "out_of_range", above_top: bool = False):
        self.reason = reason
        self.above_top = above_top
        super().__init__(message)


class NoStateInRange(ModelRangeError):
    """A curve has no valid state anywhere in the pole-stretch range asked for (its voltage or pressure lies
    outside the model's range there); ``reason`` tags the first state's failure."""


def told_apart(a: float, b: float, least: int = 4) -> tuple[str, str]:
    """``a`` and ``b`` for a message, with the fewest significant figures (at least ``least``, at most 17) at which
    they read differently: a pressure just above a bound must not print as equal to it (``1.973`` and ``1.973``).

    Parameters
    ----------
    a, b : float
        The two numbers.
    least : int
        The fewest significant figures.

    Returns
    -------
    tuple of str
        Both, formatted alike (equal only where the numbers are).

    Examples
    --------
    >>> told_apart(1.97312, 1.97305), told_apart(2.5, 1.0)
    (('1.9731', '1.973'), ('2.5', '1'))
    """
    for digits in range(least, 18):
        sa, sb = f"{a:.{digits}g}", f"{b:.{digits}g}"
        if sa != sb:
            return sa, sb
    return sa, sb
