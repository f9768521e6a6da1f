"""The installed distribution's version (``jointrig.__version__``), in a module of its own so that
any layer can read it without importing the package's entry points."""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("jointrig")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0+unknown"
