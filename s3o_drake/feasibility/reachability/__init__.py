"""The inverse reachability map: where the arm's base may stand to grasp a target
(`map.py`: loading and queries; `build.py`: building it with Drake's IK)."""
