"""porepipe: digital models of granular porous rock, built and measured."""

__version__ = "0.1.0"
