"""crumple: energy-minimal simulation of elastic wires crumpled in two dimensions.

Units: lengths in units of the wire's rest length L0 (L0 = 1 by default), energies in the units
of the paper's Eq. (1) (k_b and the energies share them; k_s is energy per length squared).
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("crumple")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

__all__ = ["__version__", "load"]


def __getattr__(name):
    # lazy, so that `import crumple` does not import xarray and pandas (no import-time cost)
    if name == "load":
        from .sweep import load

        return load
    raise AttributeError(f"module 'crumple' has no attribute {name!r}")
