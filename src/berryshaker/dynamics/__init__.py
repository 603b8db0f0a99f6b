"""Dynamics of the harvester drive with clearance: the study's MLSD model (eq. 4-12)."""

from .mlsd import MLSDResult, simulate_mlsd

__all__ = ["MLSDResult", "simulate_mlsd"]
