"""Tapered round branch: geometry and section properties (study eq. 13)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from berryshaker.errors import ConfigError


def taper_coefficient(root_diameter, tip_diameter):
    """Study eq. 13: alpha = (d0 - dm) / d0 (dimensionless, 0 = uniform, -> 1 = a complete cone).

    Parameters
    ----------
    root_diameter, tip_diameter : float
        d0 and dm (m).

    Returns
    -------
    float
        alpha (dimensionless).
    """
    return (root_diameter - tip_diameter) / root_diameter


@dataclass(frozen=True)
class Branch:
    """A branch as a linearly tapered round Euler-Bernoulli cantilever, clamped at the root (z = 0).

    Diameter d(z) = d0 (1 - alpha z / l) = d0 eta(z); area A = pi d^2/4 ~ eta^2; second moment
    I = pi d^4/64 ~ eta^4 (a truncated cone).  SI units.

    Attributes
    ----------
    root_diameter, tip_diameter : float
        d0 and dm (m), dm <= d0.
    length : float
        l (m).
    elastic_modulus : float
        E (Pa).
    density : float
        rho (kg/m^3).
    damping_ratio : float
        xi, the modal damping ratio (dimensionless), in [0, 1).
    """

    root_diameter: float  # d0 (m)
    tip_diameter: float  # dm (m)
    length: float  # l (m)
    elastic_modulus: float  # E (Pa)
    density: float  # rho (kg/m^3)
    damping_ratio: float = 0.07  # xi, modal damping ratio

    def __post_init__(self):
        if not self.length > 0:
            raise ConfigError(f"branch length must be > 0, got {self.length}")
        if not self.elastic_modulus > 0:
            raise ConfigError(f"branch elastic modulus must be > 0, got {self.elastic_modulus}")
        if not self.density > 0:
            raise ConfigError(f"branch density must be > 0, got {self.density}")
        if not self.root_diameter > 0 or not self.tip_diameter > 0:
            raise ConfigError("branch root and tip diameters must be > 0")
        if self.tip_diameter > self.root_diameter:
            raise ConfigError(f"branch tip diameter {self.tip_diameter * 1e3:g} mm is larger than the root "
                              f"diameter {self.root_diameter * 1e3:g} mm (the model tapers towards the tip)")
        if not 0 <= self.damping_ratio < 1:
            raise ConfigError(f"branch damping ratio must be in [0, 1), got {self.damping_ratio}")

    @property
    def alpha(self) -> float:
        """Taper coefficient (study eq. 13; dimensionless), :func:`taper_coefficient`."""
        return taper_coefficient(self.root_diameter, self.tip_diameter)

    def eta(self, z):
        """Diameter ratio eta(z) = d(z) / d0 = 1 - alpha z / l.

        Parameters
        ----------
        z : array_like
            Distance from the root (m).

        Returns
        -------
        ndarray
            eta (dimensionless).
        """
        return 1.0 - self.alpha * np.asarray(z, float) / self.length

    def diameter(self, z):
        """Diameter d(z) = d0 eta(z).

        Parameters
        ----------
        z : array_like
            Distance from the root (m).

        Returns
        -------
        ndarray
            d (m).
        """
        return self.root_diameter * self.eta(z)

    def area(self, z):
        """Cross-section area A(z) = pi d^2 / 4.

        Parameters
        ----------
        z : array_like
            Distance from the root (m).

        Returns
        -------
        ndarray
            A (m^2).
        """
        return math.pi * self.diameter(z) ** 2 / 4.0

    def second_moment(self, z):
        """Second moment of area I(z) = pi d^4 / 64.

        Parameters
        ----------
        z : array_like
            Distance from the root (m).

        Returns
        -------
        ndarray
            I (m^4).
        """
        return math.pi * self.diameter(z) ** 4 / 64.0

    @property
    def mass(self) -> float:
        """Total mass (kg): rho A0 l (1 - alpha + alpha^2/3)."""
        a = self.alpha
        return self.density * self.area(0.0) * self.length * (1 - a + a * a / 3)

    def check_position(self, z, what="position"):
        """Positions along the branch, refused outside 0..l.

        Parameters
        ----------
        z : array_like
            Distance from the root (m).
        what : str
            What the positions are, for the error message.

        Returns
        -------
        ndarray
            ``z`` as a float array (m).

        Raises
        ------
        ConfigError
            If a position lies outside the branch.
        """
        z = np.asarray(z, float)
        if np.any(z < 0) or np.any(z > self.length):
            raise ConfigError(f"{what} {np.atleast_1d(z).tolist()} m is outside the branch (0 .. {self.length} m)")
        return z
