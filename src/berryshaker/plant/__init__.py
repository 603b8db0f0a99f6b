"""The blueberry plant: tapered branch (study eq. 13-15), its modes (analytic Bessel and finite
elements), forced response (Duhamel), fruit harvesting force (eq. 16) and harvest condition (eq. 17)."""

from berryshaker.plant.branch import Branch, taper_coefficient
from berryshaker.plant.modes import analytic_modes, fe_modes

__all__ = ["Branch", "taper_coefficient", "analytic_modes", "fe_modes"]
