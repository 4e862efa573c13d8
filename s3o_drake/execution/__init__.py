"""What the execution diagram's controllers use: arm motion planning and pickup plans."""
