"""The simulated world: the restaurant and the robot in a MultibodyPlant with SceneGraph and
the overhead camera (builder.py), the dishes' poses as the world moves them (object_tracker.py,
with the values on its ports in dish_messages.py) and the camera's own copy of the geometry
(geometry_mirror.py)."""
