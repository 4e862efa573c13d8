"""Navigation: the map of where the base can drive (`map.py`, with its visibility graph and
segment tests), and the base's motion profile (`base_motion.py`), which the navigator plays
and the time model times."""
