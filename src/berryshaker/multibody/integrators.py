"""Shared integrator data: the Dormand-Prince 5(4) tableau used by the compiled MLSD and multibody
integrators (Hairer, Norsett & Wanner, *Solving Ordinary Differential Equations I*, 2nd ed., Table 5.2).
Row 7 of A is the 5th-order solution (FSAL); E holds b - b* for the embedded 4th-order error estimate; D the
coefficients of the continuous extension of order 4 (dense output; Hairer, Norsett & Wanner sec. II.6, as in
their code DOPRI5: y(t0 + th h) = y0 + th (dy + (1 - th) (b + th (dy - h k7 - b + (1 - th) h sum_i D_i k_i)))
with dy = y1 - y0 and b = h k1 - dy).

numba freezes these arrays into the compiled integrators as constants: this file's mention of numba puts it in
the compiled sources' digest (:func:`berryshaker.compiled_cache.compiled_sources_digest`), so a change of the
tableau recompiles them."""

import numpy as np

DOPRI_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
DOPRI_A = np.array([
    [0, 0, 0, 0, 0, 0],
    [1 / 5, 0, 0, 0, 0, 0],
    [3 / 40, 9 / 40, 0, 0, 0, 0],
    [44 / 45, -56 / 15, 32 / 9, 0, 0, 0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0],
    [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84],
])
DOPRI_E = np.array([71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40])
DOPRI_D = np.array([-12715105075 / 11282082432, 0.0, 87487479700 / 32700410799, -10690763975 / 1880347072,
                    701980252875 / 199316789632, -1453857185 / 822651844, 69997945 / 29380423])
