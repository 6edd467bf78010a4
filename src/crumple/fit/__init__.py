"""Fits with uncertainties: power laws, multivariate power laws, ensemble means, data collapse.

Every fit returns a frozen record that states the range of data it used. Every stochastic
function (the bootstraps) takes ``rng``: a :class:`numpy.random.Generator` or an integer seed
(``None`` draws fresh entropy from the operating system; no global random state is touched).

All power laws are fitted as straight lines in log-log space by (weighted) least squares,

.. math::

    \\ln y = \\ln A + a \\ln x + \\varepsilon ,

so that the errors are assumed multiplicative (log-normal) and the standard errors come from the
scatter of the residuals about the line, as in an ordinary regression. These are the fits of
the paper's Eq. (3) exponent D_M (Fig. 3), of the allocation law Eq. (4) (Fig. 4) and of the
collapse R_g ~ λ^α (k_b k_s)^c of Fig. 5.

The package has one module per concept: ``records`` (the frozen results), ``power_law``
(one power law, its bootstrap, ensemble means) and ``multi`` (Eq. 4's multivariate fit and the
collapse). Everything is imported from here.
"""

from .multi import collapse, fit_multi_power_law
from .power_law import bootstrap_power_law, fit_power_law, mean_confidence_interval
from .records import CollapseFit, MeanEstimate, MultiPowerLawFit, PowerLawFit

__all__ = [
    "CollapseFit",
    "MeanEstimate",
    "MultiPowerLawFit",
    "PowerLawFit",
    "bootstrap_power_law",
    "collapse",
    "fit_multi_power_law",
    "fit_power_law",
    "mean_confidence_interval",
]
