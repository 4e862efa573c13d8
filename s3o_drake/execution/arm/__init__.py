"""The arm's motions: collision-free paths (OMPL RRT-Connect on Drake's collision checker)
timed by TOPPRA (arm_motion.py), and the pickup motion from where the base stands
(pickup.py)."""
