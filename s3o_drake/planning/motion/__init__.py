"""Motion-level search: one base pose per goto, by CMA-ES (GROP*) or Fea^m-weighted sampling
(GROP) in `grop.py`; V-PETLON's random goals (`petlon.py`); the searched stops moved to free
ones (`free_positions.py`)."""
