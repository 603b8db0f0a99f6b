"""Picking outcome: plant population, virtual harvest (efficiency, unripe shedding, damage)."""
