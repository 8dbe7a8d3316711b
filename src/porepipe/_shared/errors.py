"""The one exception type for bad input."""


class PorepipeError(Exception):
    """Bad input or an unrecoverable state; the message names the key, file or shape and what is allowed.

    The CLI prints it without a traceback and exits with status 2.
    """
