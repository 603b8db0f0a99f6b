"""Ripeness stages of the fruit a pass meets: green, pink, red and blue, with their bond strengths and their shares
of the fruit mass (docs/harvest.md, "Ripeness stages").

A field test counts as unripe every fruit that is not blue: green, pink and red (the study's unripe rate and the
GYL062's green drop are shares of the picked mass; Sargent et al. sort harvested fruit into blue, red and green).  The
model's unripe class is therefore a mixture of three stages: ``harvest.unripe_fraction`` is its share of the fruit
mass (what a field test counts), ``harvest.unripe_stage_mix`` the shares of green, pink and red within it (summing to
1; default 0.5 / 0.25 / 0.25 [assumed]: green fruit hang for weeks before colour break, the coloured stages a few
days each, so half the unripe mass green and the other half shared equally).

**Bond strengths by stage.**  Blue: Kong et al. (2014), pull 0.47 N and shear 0.23 N about five days after turning
blue [published], strength CV ``bond_cv``.  Green: the study's eq. 17 band 1.0-3.6 N read as a lognormal's central
90 %, mean pull 2.05 N (``unripe_pull``, ``unripe_shear``, CV ``unripe_bond_cv``) [study].  Pink and red: no
published per-stage detachment force was found (the bond falls over ripening, Kong et al. 2014's pull 0.53-0.72 N
over the ripening period; cell separation in the abscission zone begins at the green-pink stage), so their mean
pulls are interpolated between the published neighbours, geometrically in the stage index k = 0 (green) .. 3 (blue)
[assumed rule]:

    P_k = P_green^(1 - k/3) P_blue^(k/3),   CV_k = CV_green (1 - k/3) + CV_blue k/3,

pink (k = 1) 1.25 N, red (k = 2) 0.77 N (0.768) at the described strengths (red near the top of Kong's ripening range,
0.72 N), unless ``pink_pull`` / ``red_pull`` give them.  Each stage's shear strength is its pull times the green
fruit's shear/pull ratio (0.488, the ripe ratio 0.489 within 0.3 % [assumed]), so a stage's load ratio is the green
fruit's ratio on the same stem load times P_green / P_k.

References
----------
Kong, D., Liu, W., Huo, J., Zhao, Y. (2014).  Test and analysis of the change of blueberry bonding force during the
ripening period.  Journal of Northeast Agricultural University 45(4) (abstract).

Lyu et al. (2024), the reference study, eq. 17 (berryshaker.reference_study).
"""

from __future__ import annotations

import numpy as np

#: the ripeness stages in order of ripening; a field test counts the first three as unripe
STAGES = ("green", "pink", "red", "blue")
UNRIPE_STAGES = STAGES[:3]


def stage_pulls(ripe_pull, green_pull, pink_pull=None, red_pull=None) -> tuple:
    """Mean pull strengths of the unripe stages (green, pink, red) (N).

    Parameters
    ----------
    ripe_pull, green_pull : float or array_like
        Mean pull strength of blue and of green fruit (N).
    pink_pull, red_pull : float, optional
        Stated pull strengths of pink and red fruit (N); default the interpolation rule.

    Returns
    -------
    tuple of (float or ndarray)
        (P_green, P_pink, P_red) (N); P_k = P_green^(1 - k/3) P_blue^(k/3) where not stated.

    Notes
    -----
    Geometric interpolation in the stage index between the published neighbours (module docstring) [assumed].
    """
    pb, pg = np.asarray(ripe_pull, float), np.asarray(green_pull, float)
    interp = [pg ** (1 - k / 3) * pb ** (k / 3) for k in (1, 2)]
    return (pg, interp[0] if pink_pull is None else np.asarray(pink_pull, float),
            interp[1] if red_pull is None else np.asarray(red_pull, float))


def stage_cvs(ripe_cv, green_cv) -> tuple:
    """Strength CVs of the unripe stages (green, pink, red), linear in the stage index (dimensionless).

    Parameters
    ----------
    ripe_cv, green_cv : float or array_like
        CV of the strength factor of blue and of green fruit (dimensionless).

    Returns
    -------
    tuple of (float or ndarray)
        (CV_green, CV_pink, CV_red), CV_k = CV_green (1 - k/3) + CV_blue k/3 [assumed].
    """
    cb, cg = np.asarray(ripe_cv, float), np.asarray(green_cv, float)
    return tuple(cg * (1 - k / 3) + cb * (k / 3) for k in (0, 1, 2))


def stage_fractions(harvest, unripe_fraction=None) -> dict:
    """Shares of the fruit mass per stage (dimensionless, summing to 1).

    Parameters
    ----------
    harvest : berryshaker.harvest.spec.HarvestSpec
        ``unripe_fraction`` and ``unripe_stage_mix``.
    unripe_fraction : float, optional
        The unripe share to use (default the description's).

    Returns
    -------
    dict of str to float
        Stage -> share: u x mix for green, pink, red; 1 - u for blue.
    """
    u = float(harvest.unripe_fraction if unripe_fraction is None else unripe_fraction)
    out = {s: u * float(c) for s, c in zip(UNRIPE_STAGES, harvest.unripe_stage_mix)}
    out["blue"] = 1.0 - u
    return out


def unripe_stage_strengths(harvest, ripe_pull=None, green_pull=None, ripe_cv=None) -> list:
    """Per unripe stage: its share of the unripe mass, the factor P_green / P_k on the green fruit's load ratio, and
    its strength CV.

    Parameters
    ----------
    harvest : berryshaker.harvest.spec.HarvestSpec
        The [harvest] block (described strengths, ``unripe_stage_mix``, ``pink_pull``, ``red_pull``).
    ripe_pull, green_pull : float or array_like, optional
        Mean pull of blue and green fruit (N; default the described; arrays of shape (n, 1) give n rows).  A stated
        pink or red pull is scaled with the green pull's ratio to the described one.
    ripe_cv : float or array_like, optional
        CV of the blue fruit's strength (dimensionless; default ``bond_cv``).

    Returns
    -------
    list of (float, ndarray, ndarray)
        (share c_s, load factor P_green,described / P_s, CV_s) for green, pink and red (dimensionless).  The load
        ratio of the green channel is at the described green strengths, hence the described green pull on top.
    """
    h = harvest
    pb = h.ripe_pull if ripe_pull is None else ripe_pull
    pg = h.unripe_pull if green_pull is None else green_pull
    scale = np.asarray(pg, float) / h.unripe_pull
    pink = None if h.pink_pull is None else h.pink_pull * scale
    red = None if h.red_pull is None else h.red_pull * scale
    pulls = stage_pulls(pb, pg, pink, red)
    cvs = stage_cvs(h.bond_cv if ripe_cv is None else ripe_cv, h.unripe_bond_cv)
    return [(float(c), h.unripe_pull / p, cv) for c, p, cv in zip(h.unripe_stage_mix, pulls, cvs)]
