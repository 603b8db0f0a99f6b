"""A harvest response added the way a user adds one: one row of the response table
(berryshaker.harvest.virtual.responses.register_response), here ripe fruit left on the bushes per minute of
harvesting; registered for a test and removed after it."""

from __future__ import annotations

import contextlib

from berryshaker.harvest.virtual.responses import RESPONSES, HarvestResponse, _ratio, register_response


def ripe_left(calibrated: bool = False) -> HarvestResponse:
    """Ripe mass left on the stretch per minute of harvesting (kg/min; smaller is better)."""
    return HarvestResponse("ripe_left", "kg/min", False, 0.01, "ripe left on the bushes",
                           "ripe mass not detached per minute of harvesting",
                           lambda t: _ratio(t.ripe - t.ripe_picked, t.duration, 60.0), calibrated=calibrated,
                           floor=0.05)


@contextlib.contextmanager
def registered(response: HarvestResponse):
    """``response`` in the table for the ``with`` block."""
    register_response(response)
    try:
        yield response
    finally:
        RESPONSES.pop(response.name, None)
