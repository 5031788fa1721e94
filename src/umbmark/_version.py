"""The installed version of umbmark (``0.0.0+unknown`` in a source tree that is not installed)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("umbmark")
except PackageNotFoundError:  # a source tree without installation
    __version__ = "0.0.0+unknown"
