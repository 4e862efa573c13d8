"""Build a robot's parts from their makers' files.

    s3o build model NAME

For each part of models/NAME/robot.yaml that names a `xacro`, writes its `model` (a URDF)
and the part's meshes as OBJ into models/NAME/generated/ (emptied first), from the makers'
files under models/parts/ (world/maker_models.py). Needs the `xacro` and `trimesh`
packages (pip install -e ".[robots]"). `s3o build robot NAME` runs it as its first step.
"""

import sys

from s3o_drake.commands.common import (
    add_robot_name,
    command_parser,
    fail,
    read_robot_description,
)


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("build model", __doc__)
    add_robot_name(parser)
    args = parser.parse_args(argv)
    from s3o_drake.world.maker_models import build_parts
    from s3o_drake.world.resources import repo_path, robot_dir
    from s3o_drake.world.robot_description import RobotDescriptionError, check_model

    description = read_robot_description(args.name)
    if not any(part.xacro for part in description.parts):
        fail(f"{args.name}: no part is built from a xacro; nothing to build")
    try:
        import trimesh  # noqa: F401
        import xacro  # noqa: F401
    except ImportError as e:
        fail(f"{e.name} is not installed: pip install -e \".[robots]\"")
    written = build_parts(description, robot_dir(args.name))
    try:
        check_model(description)
    except RobotDescriptionError as e:
        fail(f"{args.name}: the built model does not agree with the description: {e}")
    print(f"{args.name}: {len(written)} files in "
          f"{repo_path(written[0].parent)}/ (the parts' URDF and their meshes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
