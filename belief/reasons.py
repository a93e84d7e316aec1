"""A verdict's reason: the rule that decided it, for code, and the words a user reads.

A reason is the string ``"<rule>: <words>"`` (:func:`because`). The rule, a key of :data:`RULES`
(belief.verdicts explains each), lets code tell which check decided a verdict (:func:`rule_of`,
``Belief.rules``); its name means nothing to someone reading a report, so what a user reads is
:func:`plain_reason`, the words alone. The words speak of the data, the search, the posterior and
the prior box, never of the rules' arithmetic (std ratios, thresholds, the GP's nats), and say a
spread at or above the prior's as "as wide as" or "wider than", not as a percentage above 100.
"""
from __future__ import annotations

from belief.errors import BeliefError

__all__ = ["RULES", "because", "rule_of", "plain_reason", "share_of", "narrowed"]

#: the verdict rules in the order of belief.verdicts' docstring: name -> what it checks
RULES: dict[str, str] = {
    "reach": "the decoder varies the parameter over enough of its box to have tried other values",
    "narrowing": "P's std over the prior's std, against identified_ratio and weak_ratio",
    "local width": "the local posterior std over all parameters, when wider than P's",
    "segment consistency": "segments that each narrow the parameter agree on its interval",
    "verified mass": "how much of P lies on cells whose likelihood the GP knows",
    "evaluated support": "the interval holds the best evaluated value",
    "local refit": "a Gauss-Newton step from the best evaluation stays inside the interval",
    "at bound": "the fitted value is not pinned at a bound of the box",
    "structure": "the value does not hang on which other parts the model was given (applied by criticism)",
}


def because(rule: str, text: str) -> str:
    """The reason ``"<rule>: <text>"`` of a verdict decided by ``rule`` (a key of :data:`RULES`)."""
    if rule not in RULES:
        raise BeliefError(f"unknown verdict rule {rule!r}; the rules are {list(RULES)}.")
    return f"{rule}: {text}"


def rule_of(reason: str) -> str:
    """The rule that decided a verdict, read from its reason (:func:`because`), or "" for a reason
    that names none (a Belief built by hand)."""
    head = reason.split(":", 1)[0]
    return head if head in RULES and ":" in reason else ""


def plain_reason(reason: str) -> str:
    """A verdict's reason as a user reads it: the words after the rule's name (:func:`because`), which
    names a check of belief.verdicts, not something the reader knows; a reason naming no rule unchanged."""
    return reason.split(":", 1)[1].strip() if rule_of(reason) else reason


def share_of(ratio: float, whole: str) -> str:
    """"12% of WHOLE" below 100 %, else "as wide as WHOLE" or "wider than WHOLE": no narrowing, said plainly."""
    return f"{ratio:.0%} of {whole}" if ratio < 0.995 else f"{'as wide as' if ratio < 1.05 else 'wider than'} {whole}"


def narrowed(ratio: float, whole: str = "its prior spread") -> str:
    """What the data did to a parameter whose std is ``ratio`` x that of ``whole``, in words."""
    part = share_of(ratio, whole)
    return f"the data narrow it to {part}" if ratio < 0.995 else f"the data do not narrow it: it stays {part}"
