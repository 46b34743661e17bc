"""Exceptions and warnings raised by sklearn-pycc."""

from __future__ import annotations

__all__ = [
    "DomainWarning",
    "ExtrapolationWarning",
    "GaugeWarning",
    "IdentifiabilityError",
    "RankDeficiencyWarning",
    "SimulationError",
    "SkeletonError",
    "StartsWarning",
]


class SkeletonError(ValueError):
    """A skeleton or a constraint cannot be understood.

    The message names the equation (or constraint) and the position, and
    shows the text with a caret under the offending character.

    Attributes
    ----------
    equation : int or None
        Index of the offending equation (or constraint) in the list given.
    position : int or None
        Offset of the offending character in that text.
    text : str or None
        The offending text.
    """

    def __init__(
        self,
        message: str,
        *,
        equation: int | None = None,
        position: int | None = None,
        text: str | None = None,
        kind: str = "equations",
    ) -> None:
        self.reason = message
        self.equation = equation
        self.position = position
        self.text = text
        parts = []
        if equation is not None or position is not None:
            where = kind if equation is None else f"{kind}[{equation}]"
            if position is not None:
                where += f", position {position}"
            parts.append(f"{where}: {message}")
        else:
            parts.append(message)
        if text is not None:
            parts.append("    " + text)
            if position is not None:
                parts.append("    " + " " * position + "^")
        super().__init__("\n".join(parts))


class IdentifiabilityError(ValueError):
    """A skeleton is not identifiable and ``gauge="raise"`` was asked for."""


class SimulationError(RuntimeError):
    """A simulation diverged or the solver failed.

    Attributes
    ----------
    t_reached : float
        The last time the solver reached with finite states.
    partial : pandas.DataFrame
        The trajectory up to ``t_reached`` on the requested output times.
    """

    def __init__(self, message: str, *, t_reached: float, partial) -> None:
        self.t_reached = t_reached
        self.partial = partial
        super().__init__(f"{message} (reached t={t_reached:.6g})")


class GaugeWarning(UserWarning):
    """A skeleton is not identifiable and ``gauge="warn"`` was asked for."""


class RankDeficiencyWarning(UserWarning):
    """The design matrix of a fit is rank deficient on the given data."""


class StartsWarning(UserWarning):
    """Starts of an output-error fit end equally well at different parameters (``starts_``)."""


class ExtrapolationWarning(UserWarning):
    """A simulation took a fitted curve outside the range it was trained on."""


class DomainWarning(RuntimeWarning):
    """A prediction is not finite: a term left its function's domain or overflowed."""
