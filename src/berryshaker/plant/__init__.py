"""The blueberry plant: tapered branch (study eq. 13-15), its modes (analytic Bessel and finite
elements), forced response (Duhamel), fruit harvesting force (eq. 16) and harvest condition (eq. 17)."""

from .branch import Branch, taper_coefficient
from .modes import analytic_modes, fe_modes

__all__ = ["Branch", "taper_coefficient", "analytic_modes", "fe_modes"]
