"""The one exception type for bad input."""


class PorepipeError(Exception):
    """Bad input or an unrecoverable state; the message names the key, file or shape and what is allowed.

    The CLI prints it without a traceback and exits with status 2.
    """


class UnstableRunError(PorepipeError):
    """A simulation went numerically unstable (a runaway or non-finite state): its parameters, not its input, are at
    fault, so a caller that chose them (acquire-calibrate's matching) can choose others.
    """


def positive_number(name: str, value) -> float:
    """``value`` as a float if it is positive and finite, else one line naming ``name`` (the check the stages share)."""
    number = float(value)
    if not 0.0 < number < float("inf"):
        raise PorepipeError(f"{name} must be a positive finite number, got {number!r}")
    return number
