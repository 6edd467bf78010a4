"""crumple: energy-minimal simulation of elastic wires crumpled in two dimensions.

Units: lengths in units of the wire's rest length L0 (L0 = 1 by default), energies in the units
of the paper's Eq. (1) (k_b and the energies share them; k_s is energy per length squared).
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("crumple")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

__all__ = ["__version__"]
