"""One registry of normal contact-force laws, read by the description validation, the compiled engine and
the configuration.

Adding a law is one compiled function and one :func:`register_law` call::

    from numba import njit
    from berryshaker.contact.laws import LAW_SIGNATURE, register_law

    @njit(LAW_SIGNATURE, cache=True)
    def cubic_law(pen, pen_dot, v_imp, k, n, e, c, d):
        return k * pen**3

    register_law("cubic", cubic_law, uses=("stiffness",), description="F = k delta^3")

Every law has the same compiled signature ``f(pen, pen_dot, v_imp, k, n, e, c, d) -> force`` with

========  =====================================================================  ==========
pen       penetration delta beyond the clearance (> 0 in contact)                m
pen_dot   its rate (> 0 while the bodies approach)                               m/s
v_imp     approach speed at the onset of this contact (for restitution laws)     m/s
k         stiffness                                                              N/m^n
n         exponent                                                               1
e         coefficient of restitution                                             1
c         damping coefficient (viscous laws; cmax of IMPACT), or, for the        N s/m,
          hysteresis laws, the restitution velocity v_ref (they have no          or m/s
          viscous coefficient; :func:`slot_c` fills the slot)
d         penetration at which full damping is reached (IMPACT)                  m
========  =====================================================================  ==========

and returns the magnitude of the repulsive normal force (N), never negative.  The engine calls it only for
``pen > 0``.  The engine passes the registered functions to its compiled core as a tuple of first-class
functions (numba), so a law registered at run time is dispatched like the built-in ones (the core is
compiled once per number of registered laws; the built-in set is cached on disk).  The tuple holds each law's
:class:`LawEntryPoint` (its compiled entry point, typed by the signature alone), not the dispatcher: numba
re-derives a dispatcher's function type from its compiled overloads at every call of the core, which cost
0.3 ms of each call.

The physics and references of each built-in law are in :mod:`berryshaker.contact.force_laws`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

from numba import float64, njit, types
from numba.core.errors import NumbaExperimentalFeatureWarning

from berryshaker.contact.force_laws import hysteresis_kernel, impact_kernel, mlsd_kernel
from berryshaker.errors import ConfigError

try:  # numba's helper for a dispatcher's wrapper address (private: without it the core gets the dispatchers)
    from numba.experimental.function_type import _get_wrapper_address
except ImportError:  # pragma: no cover - a numba that moved it
    _get_wrapper_address = None

warnings.filterwarnings("ignore", category=NumbaExperimentalFeatureWarning)

#: the compiled signature every law has: (pen, pen_dot, v_imp, k, n, e, c, d) -> force
LAW_SIGNATURE = float64(float64, float64, float64, float64, float64, float64, float64, float64)

#: the law parameters a contact description can set, with their units
LAW_PARAMETERS = {
    "stiffness": "N/m^n", "exponent": "1", "restitution": "1", "damping": "N*s/m", "damping_depth": "m",
    "restitution_velocity": "m/s",
}
#: parameters that share the compiled slot ``c`` (a law reads at most one of them)
SLOT_C_PARAMETERS = ("damping", "restitution_velocity")


@dataclass(frozen=True)
class ContactLaw:
    """A registered normal force law.

    Attributes
    ----------
    name : str
        The name descriptions use.
    kernel : numba dispatcher
        The compiled law, with :data:`LAW_SIGNATURE`.
    uses : tuple of str
        Which of :data:`LAW_PARAMETERS` it reads.
    description : str
        One line for ``config show`` and the docs.
    code : int
        Its index in the engine's law table.
    monotone : bool
        The force never decreases as pen or pen_dot grows (other inputs fixed).
    """

    name: str
    kernel: object  # numba dispatcher with LAW_SIGNATURE
    uses: tuple[str, ...]  # which of LAW_PARAMETERS it reads
    description: str
    code: int
    monotone: bool = False  # the force never decreases as pen or pen_dot grows (other inputs fixed)


_LAWS: dict[str, ContactLaw] = {}


class LawEntryPoint(types.WrapperAddressProtocol):
    """A registered law's compiled entry point, as the engine's core receives it.

    numba types it from :data:`LAW_SIGNATURE` alone and unboxes it by its stored address, so passing a tuple
    of them costs nothing per call (a tuple of dispatchers is unified into the same function type at every
    call, by inspecting each dispatcher's overloads).  Inside compiled code the call is the same indirect call
    through the same address; from Python it calls the law's dispatcher.

    Parameters
    ----------
    kernel : numba dispatcher
        The law's compiled kernel, with :data:`LAW_SIGNATURE`.
    """

    def __init__(self, kernel):
        self.kernel = kernel
        self._address = None

    def __wrapper_address__(self) -> int:
        if self._address is None:
            self._address = _get_wrapper_address(self.kernel, LAW_SIGNATURE)
        return self._address

    def signature(self):
        """The numba signature of every law, :data:`LAW_SIGNATURE`.

        Returns
        -------
        numba.core.typing.templates.Signature
            float64(float64 x 8).
        """
        return LAW_SIGNATURE

    def __call__(self, *args):
        return self.kernel(*args)


#: one entry point per law kernel, so the engine's law tuple keeps its identity between runs
_ENTRY_POINTS: dict[int, LawEntryPoint] = {}


def register_law(name: str, kernel, uses: tuple[str, ...], description: str, monotone: bool = False) -> ContactLaw:
    """Register a compiled force law under ``name`` (see the module docstring for the signature).

    Parameters
    ----------
    name : str
        The name descriptions use (``contact.law = "name"``).
    kernel : numba dispatcher
        Compiled with :data:`LAW_SIGNATURE`.
    uses : tuple of str
        The parameters of :data:`LAW_PARAMETERS` the law reads (validation requires them to be set).
    description : str
        One line shown by ``berryshaker config show`` and the docs.
    monotone : bool
        True if the force never decreases as the penetration or its rate grows (at fixed impact velocity and
        parameters).  The engine then bounds the force inside a step by one evaluation at the step's largest
        penetration and rate, and skips the interior-peak search of steps that cannot raise a recorded
        maximum (docs/multibody.md).  A wrong True can hide a peak: tests/contact/test_laws.py checks
        every law that claims it.  Default False (always search).

    Returns
    -------
    ContactLaw
        The registered law (a law registered again keeps its code).
    """
    if not name.isidentifier():
        raise ConfigError(f"contact law name {name!r} must be an identifier (letters, digits, underscores)")
    unknown = [u for u in uses if u not in LAW_PARAMETERS]
    if unknown:
        raise ConfigError(f"contact law {name!r}: unknown parameters {unknown}; choose from {list(LAW_PARAMETERS)}")
    if all(p in uses for p in SLOT_C_PARAMETERS):
        raise ConfigError(f"contact law {name!r}: 'damping' and 'restitution_velocity' share the compiled slot c; "
                          "a law reads one of them")
    sigs = getattr(kernel, "signatures", None)
    if not sigs or tuple(sigs[0]) != tuple(LAW_SIGNATURE.args):
        raise ConfigError(f"contact law {name!r}: compile the kernel with @njit(LAW_SIGNATURE) "
                          "(berryshaker.contact.laws.LAW_SIGNATURE)")
    code = _LAWS[name].code if name in _LAWS else len(_LAWS)
    law = ContactLaw(name, kernel, tuple(uses), description, code, bool(monotone))
    _LAWS[name] = law
    return law


def unregister_law(name: str) -> None:
    """Remove a law registered at run time (built-in laws cannot be removed).

    Parameters
    ----------
    name : str
        The law's name.
    """
    if name in BUILT_IN:
        raise ConfigError(f"{name!r} is a built-in contact law")
    _LAWS.pop(name, None)
    for i, law in enumerate(sorted(_LAWS.values(), key=lambda x: x.code)):
        _LAWS[law.name] = ContactLaw(law.name, law.kernel, law.uses, law.description, i, law.monotone)


def get_law(name: str) -> ContactLaw:
    """The registered law called ``name``; a clear error listing the names otherwise.

    Parameters
    ----------
    name : str
        The law's name.

    Returns
    -------
    ContactLaw
        The law.
    """
    try:
        return _LAWS[name]
    except KeyError:
        raise ConfigError(f"unknown contact law {name!r}; registered laws: {', '.join(law_names())}") from None


def law_names() -> tuple[str, ...]:
    """Names of the registered laws, in registration order.

    Returns
    -------
    tuple of str
        The names.
    """
    return tuple(sorted(_LAWS, key=lambda n: _LAWS[n].code))


def slot_c(name: str, damping: float, restitution_velocity: float) -> float:
    """The value of the compiled slot ``c`` for law ``name``: ``restitution_velocity`` (m/s) if the law reads
    it (the hysteresis laws), else ``damping`` (N s/m).

    Parameters
    ----------
    name : str
        The law's name.
    damping : float
        Damping coefficient (N s/m).
    restitution_velocity : float
        Restitution velocity v_ref (m/s).

    Returns
    -------
    float
        The slot's value (m/s or N s/m).
    """
    return float(restitution_velocity if "restitution_velocity" in get_law(name).uses else damping)


def law_table() -> tuple:
    """The compiled kernels' entry points (:class:`LawEntryPoint`) in code order, as the engine's core receives
    them (the dispatchers themselves if this numba has no ``_get_wrapper_address``: the same results, typed at
    every call).

    Returns
    -------
    tuple
        One entry point per law.
    """
    if _get_wrapper_address is None:  # pragma: no cover
        return tuple(_LAWS[n].kernel for n in law_names())
    out = []
    for n in law_names():
        kernel = _LAWS[n].kernel
        entry = _ENTRY_POINTS.get(id(kernel))
        if entry is None or entry.kernel is not kernel:
            entry = _ENTRY_POINTS[id(kernel)] = LawEntryPoint(kernel)
        out.append(entry)
    return tuple(out)


# ---- built-in laws ---------------------------------------------------------------------------------
@njit(LAW_SIGNATURE, cache=True)
def mlsd_law(pen, pen_dot, v_imp, k, n, e, c, d):
    """Linear spring-damper (study eq. 8, consistent reading): max(0, k pen + c pen_dot).

    Parameters
    ----------
    pen, pen_dot : float
        Penetration beyond the clearance (m) and its rate (m/s, > 0 approaching).
    v_imp : float
        Approach speed at the onset of this contact (m/s).
    k : float
        Stiffness (N/m^n).
    n : float
        Exponent (dimensionless).
    e : float
        Coefficient of restitution (dimensionless).
    c : float
        Slot c: damping (N s/m) or restitution velocity v_ref (m/s), :func:`slot_c`.
    d : float
        Penetration of full damping (m; IMPACT).

    Returns
    -------
    float
        Normal force (N), >= 0.
    """
    return mlsd_kernel(pen, pen_dot, k, c)


@njit(LAW_SIGNATURE, cache=True)
def hertz_law(pen, pen_dot, v_imp, k, n, e, c, d):
    """Hertz, elastic: k pen^n.

    Parameters
    ----------
    pen, pen_dot : float
        Penetration beyond the clearance (m) and its rate (m/s, > 0 approaching).
    v_imp : float
        Approach speed at the onset of this contact (m/s).
    k : float
        Stiffness (N/m^n).
    n : float
        Exponent (dimensionless).
    e : float
        Coefficient of restitution (dimensionless).
    c : float
        Slot c: damping (N s/m) or restitution velocity v_ref (m/s), :func:`slot_c`.
    d : float
        Penetration of full damping (m; IMPACT).

    Returns
    -------
    float
        Normal force (N), >= 0.
    """
    return k * pen**n


@njit(cache=True)
def hysteresis_velocity(v_imp, v_ref):
    """The velocity the hysteresis factor divides by: max(|v_imp|, v_ref) (m/s).

    Below the restitution velocity v_ref the damping is that of an impact at v_ref: the hysteresis
    coefficient alpha = f(e)/v_ref is then a material constant (Hunt & Crossley 1975), so an impact at
    v < v_ref has 1 - e(v)^2 = (1 - e^2) v / v_ref for small damping, and e -> 1 as v -> 0
    (docs/contact.md sec. 6.4).  v_ref = 0: the published laws (f(e)/v_imp at every speed).

    Parameters
    ----------
    v_imp : float
        Approach speed at the onset of the contact (m/s).
    v_ref : float
        Restitution velocity (m/s), >= 0.

    Returns
    -------
    float
        max(|v_imp|, v_ref) (m/s).
    """
    v = abs(v_imp)
    return v if v > v_ref else v_ref


@njit(LAW_SIGNATURE, cache=True)
def hunt_crossley_law(pen, pen_dot, v_imp, k, n, e, c, d):
    """Hunt & Crossley (1975) with the factor 3(1-e)/2; slot c = restitution velocity v_ref (m/s).

    Parameters
    ----------
    pen, pen_dot : float
        Penetration beyond the clearance (m) and its rate (m/s, > 0 approaching).
    v_imp : float
        Approach speed at the onset of this contact (m/s).
    k : float
        Stiffness (N/m^n).
    n : float
        Exponent (dimensionless).
    e : float
        Coefficient of restitution (dimensionless).
    c : float
        Slot c: damping (N s/m) or restitution velocity v_ref (m/s), :func:`slot_c`.
    d : float
        Penetration of full damping (m; IMPACT).

    Returns
    -------
    float
        Normal force (N), >= 0.
    """
    return hysteresis_kernel(pen, pen_dot, hysteresis_velocity(v_imp, c), k, 1.5 * (1.0 - e), n)


@njit(LAW_SIGNATURE, cache=True)
def lankarani_nikravesh_law(pen, pen_dot, v_imp, k, n, e, c, d):
    """Lankarani & Nikravesh (1990) with the factor 3(1-e^2)/4; slot c = restitution velocity v_ref (m/s).

    F = K delta^n [1 + 3 (1 - e^2) delta_dot / (4 max(v_imp, v_ref))] (N), >= 0: the configured e at impact
    speeds >= v_ref, Hunt & Crossley's material-constant hysteresis below (docs/contact.md sec. 6.4).

    Parameters
    ----------
    pen, pen_dot : float
        Penetration beyond the clearance (m) and its rate (m/s, > 0 approaching).
    v_imp : float
        Approach speed at the onset of this contact (m/s).
    k : float
        Stiffness (N/m^n).
    n : float
        Exponent (dimensionless).
    e : float
        Coefficient of restitution (dimensionless).
    c : float
        Slot c: damping (N s/m) or restitution velocity v_ref (m/s), :func:`slot_c`.
    d : float
        Penetration of full damping (m; IMPACT).

    Returns
    -------
    float
        Normal force (N), >= 0.
    """
    return hysteresis_kernel(pen, pen_dot, hysteresis_velocity(v_imp, c), k, 0.75 * (1.0 - e * e), n)


@njit(LAW_SIGNATURE, cache=True)
def flores_law(pen, pen_dot, v_imp, k, n, e, c, d):
    """Flores et al. (2011) with the factor 8(1-e)/(5e); slot c = restitution velocity v_ref (m/s).

    Parameters
    ----------
    pen, pen_dot : float
        Penetration beyond the clearance (m) and its rate (m/s, > 0 approaching).
    v_imp : float
        Approach speed at the onset of this contact (m/s).
    k : float
        Stiffness (N/m^n).
    n : float
        Exponent (dimensionless).
    e : float
        Coefficient of restitution (dimensionless).
    c : float
        Slot c: damping (N s/m) or restitution velocity v_ref (m/s), :func:`slot_c`.
    d : float
        Penetration of full damping (m; IMPACT).

    Returns
    -------
    float
        Normal force (N), >= 0.
    """
    return hysteresis_kernel(pen, pen_dot, hysteresis_velocity(v_imp, c), k, 1.6 * (1.0 - e) / e, n)


@njit(LAW_SIGNATURE, cache=True)
def impact_law(pen, pen_dot, v_imp, k, n, e, c, d):
    """ADAMS IMPACT: k pen^n + STEP(pen, 0, 0, d, cmax) pen_dot.

    Parameters
    ----------
    pen, pen_dot : float
        Penetration beyond the clearance (m) and its rate (m/s, > 0 approaching).
    v_imp : float
        Approach speed at the onset of this contact (m/s).
    k : float
        Stiffness (N/m^n).
    n : float
        Exponent (dimensionless).
    e : float
        Coefficient of restitution (dimensionless).
    c : float
        Slot c: damping (N s/m) or restitution velocity v_ref (m/s), :func:`slot_c`.
    d : float
        Penetration of full damping (m; IMPACT).

    Returns
    -------
    float
        Normal force (N), >= 0.
    """
    return impact_kernel(-pen, -pen_dot, 0.0, k, n, c, d)


# monotone: max(0, k pen + c pen_dot) and max(0, k pen^n (1 + f pen_dot / v)) never decrease as pen or pen_dot
# grows (c, f >= 0); IMPACT's damping ramps in with pen, so at pen_dot < 0 the force can fall as pen grows
register_law("mlsd", mlsd_law, ("stiffness", "damping"), "linear spring-damper, study eq. 8 (consistent reading)",
             monotone=True)
register_law("hertz", hertz_law, ("stiffness", "exponent"), "Hertz power law k delta^n, elastic", monotone=True)
_HYSTERESIS_USES = ("stiffness", "exponent", "restitution", "restitution_velocity")
register_law("hunt_crossley", hunt_crossley_law, _HYSTERESIS_USES,
             "Hunt-Crossley hysteresis damping, 3(1-e)/2 / max(v_imp, v_ref)", monotone=True)
register_law("lankarani_nikravesh", lankarani_nikravesh_law, _HYSTERESIS_USES,
             "Lankarani-Nikravesh hysteresis damping, 3(1-e^2)/4 / max(v_imp, v_ref)", monotone=True)
register_law("flores", flores_law, _HYSTERESIS_USES, "Flores hysteresis damping, 8(1-e)/(5e) / max(v_imp, v_ref)",
             monotone=True)
register_law("impact", impact_law, ("stiffness", "exponent", "damping", "damping_depth"),
             "ADAMS IMPACT function: k delta^n with damping ramped to cmax over d")

BUILT_IN = frozenset(law_names())
