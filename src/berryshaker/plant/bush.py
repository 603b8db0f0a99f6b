"""The bush as the combs' load: a seeded population of branches, each a tapered cantilever with a few modes.

Each member is a tapered round Euler-Bernoulli cantilever (study eq. 13-15, :mod:`berryshaker.plant.modes`)
standing at its own place along the row, leaning by its own angle in the combs' plane and reaching its own
height.  The combs' striking finger section meets a member where the member's axis crosses the finger
height h_f (a planar reading of the over-the-row head: the fingers work at one height):

    z_c = (h_f - h_b) / cos(lean),  station s = z_c / l  (reached when 0 < s <= 1),

and pushes it along the in-plane normal of its axis, n = (cos lean, -sin lean) for an axis direction
(sin lean, cos lean) from vertical.  A member leaning towards -x (lean < 0) stands on the left comb's
side and is struck by it; lean > 0 by the right comb.  The member's lateral offset is where its surface
lies relative to the finger's mid-stroke position: > 0 overlaps the finger at mid-stroke (engaged over
more of the stroke), < 0 is reached only near the end of the stroke.

The distributions are uniform over the ranges of :class:`berryshaker.plant.spec.BushSpec` ([assumed]
unless marked there), sampled by a Latin hypercube (scipy.stats.qmc) seeded through numpy's PCG64: the
same seed gives the same bush.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from berryshaker.plant.branch import Branch
from berryshaker.plant.modes import Modes, cached_analytic_modes


@dataclass(frozen=True)
class BushBranch:
    """One member of the bush population (SI units).

    Attributes
    ----------
    name : str
        The member's name.
    branch : Branch
        Its geometry and material.
    base_height : float
        Where it leaves the crown, above the reference base (m).
    lean : float
        Signed angle of its axis from vertical in the combs' plane (rad), > 0 towards +x.
    row_offset : float
        Position along the row relative to the instrumented branch (m).
    lateral_offset : float
        Its surface relative to the finger's mid-stroke position (m), > 0: overlap.
    comb : {"left", "right"}
        The comb that strikes it.
    station : float or None
        Fraction of its length where the fingers meet it; None: out of their reach.
    """

    name: str
    branch: Branch  # geometry and material
    base_height: float  # where it leaves the crown, above the reference base (m)
    lean: float  # signed angle of its axis from vertical in the combs' plane (rad), > 0 towards +x
    row_offset: float  # position along the row relative to the instrumented branch (m)
    lateral_offset: float  # surface relative to the finger's mid-stroke position (m), > 0: overlap
    comb: str  # "left" or "right": the comb that strikes it
    station: float | None  # fraction of its length where the fingers meet it; None: out of their reach

    @property
    def normal(self) -> tuple[float, float]:
        """Unit in-plane normal of its axis, the direction the finger pushes it (bending direction)."""
        return (math.cos(self.lean), -math.sin(self.lean))


def sample_bush(plant) -> list[BushBranch]:
    """The seeded branch population of ``plant.bush`` (:class:`~berryshaker.plant.spec.PlantSpec`).

    Parameters
    ----------
    plant : berryshaker.plant.spec.PlantSpec
        Plant section; ``plant.bush`` gives the ranges and the seed, ``plant.branch`` the material
        (E, rho, damping ratio) shared by every member.

    Returns
    -------
    list of BushBranch
        ``plant.bush.members`` sampled members, reached by the fingers or not (``station`` None), in drawing
        order; each stands for :func:`member_weight` branches of the bush.
    """
    from scipy.stats import qmc

    bs = plant.bush
    n = bs.members
    # Latin hypercube: each of the seven distributions is sampled once in each of n equal-probability strata
    # (McKay, Beckman & Conover 1979), so a small sample covers every range -- the comb's load, a sum over the
    # members, then converges with far fewer members than with independent draws; half go to each comb.
    u = qmc.LatinHypercube(d=7, seed=np.random.default_rng(bs.seed)).random(n) if n else np.zeros((0, 7))

    def scale(j, lo, hi):
        return lo + u[:, j] * (hi - lo)

    d0 = scale(0, *bs.root_diameter)
    length = scale(1, *bs.length)
    base = scale(2, *bs.base_height)
    lean_mag = scale(3, *bs.lean)
    left = u[:, 4] < 0.5
    row = scale(5, -bs.row_spread / 2, bs.row_spread / 2)
    lateral = scale(6, -bs.lateral_spread, bs.lateral_spread)
    mat = plant.branch
    out = []
    for i in range(n):
        lean = -lean_mag[i] if left[i] else lean_mag[i]
        br = Branch(float(d0[i]), float(d0[i] * bs.tip_ratio), float(length[i]), mat.elastic_modulus, mat.density,
                    mat.damping_ratio)
        s = (bs.finger_height - base[i]) / (math.cos(lean) * length[i])
        out.append(BushBranch(f"bush_{i + 1}", br, float(base[i]), float(lean), float(row[i]), float(lateral[i]),
                              "left" if left[i] else "right", float(s) if 0.0 < s <= 1.0 else None))
    return out


def member_weight(bush_spec) -> float:
    """Branches of the bush each simulated member stands for in the comb's load: branches / members (the
    instrumented fruit branch is one of the bush's branches, represented by the sample like the others; it
    is driven by the combs without acting back); 0 without members.

    Parameters
    ----------
    bush_spec : BushSpec
        The ``[plant.bush]`` section (``branches``, ``members``).

    Returns
    -------
    float
        Branches per simulated member (1).
    """
    return bush_spec.branches / bush_spec.members if bush_spec.members else 0.0


def member_modes(member: BushBranch, n_modes: int) -> Modes:
    """Analytic modes (study eq. 15) of one member, cached per process (the same seed repeats them).

    Parameters
    ----------
    member : BushBranch
        The member.
    n_modes : int
        Number of bending modes.

    Returns
    -------
    Modes
        Its mass-normalised modes.
    """
    b = member.branch
    key = (b.root_diameter, b.tip_diameter, b.length, b.elastic_modulus, b.density, b.damping_ratio)
    return cached_analytic_modes(key, n_modes)
