"""Clearance over the machine's life: ISO 286 fits (the clearance a new machine leaves the shop with) and
the wear loop that grows it towards the study's levels (:mod:`berryshaker.life.fits`, the limits of a class in
:mod:`berryshaker.life.iso286_limits`, :mod:`berryshaker.life.wear`; the service limit and the machine's wear loop in
:mod:`berryshaker.life.service`; Archard's law is in :mod:`berryshaker.contact.wear`).  See docs/life.md."""

from berryshaker.life.fits import Fit, fit_summary, iso_fit, parse_fit
from berryshaker.life.iso286_limits import ToleranceZone, tolerance_zone
from berryshaker.life.service import machine_wear, service_limits
from berryshaker.life.wear import JointWear, WearLife, clearance_size_from_fit, wear_life

__all__ = [
           "Fit",
           "JointWear",
           "ToleranceZone",
           "WearLife",
           "clearance_size_from_fit",
           "fit_summary",
           "iso_fit",
           "machine_wear",
           "parse_fit",
           "service_limits",
           "tolerance_zone",
           "wear_life",
]
