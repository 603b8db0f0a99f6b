"""Kinematics of the harvester drive: groove cam (study eq. 1-2) and double rocker (eq. 3)."""

from berryshaker.kinematics.cam import (
    FOLLOWER_LAWS,
    follower_law,
    follower_svaj,
    groove_profile,
    pitch_curve,
    pitch_curve_curvature,
    pressure_angle,
)
from berryshaker.kinematics.linkage import four_bar_position, four_bar_rates, left_comb_angle, transmission_angle

__all__ = [
    "FOLLOWER_LAWS",
    "follower_law",
    "follower_svaj",
    "groove_profile",
    "pitch_curve",
    "pitch_curve_curvature",
    "pressure_angle",
    "left_comb_angle",
    "four_bar_position",
    "four_bar_rates",
    "transmission_angle",
]
