"""The version of porepipe (its own module, so low-level modules can name it without importing the package)."""

__version__ = "0.1.0"
