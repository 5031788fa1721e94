"""umbmark: measure and correct systematic odometry errors of differential-drive robots."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("umbmark")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

from .errors import CorrectionUndefined, InputError, UmbmarkError  # noqa: E402

__all__ = ["__version__", "UmbmarkError", "InputError", "CorrectionUndefined"]
