"""A room as Drake model directives: the scene that any Drake tool opens.

`write_directives` writes a folder that is a package of its own (package.xml), with the
robot's URDF (a robot of parts: its parts' model files and the meshes they name, under
robot/ as they are under models/), an SDFormat file per table, chair and dish, one for the
room's floor and walls, and `<name>.dmd.yaml`, Drake's model directives that put them where
the project's builder (`builder.populate_plant`) puts them: the robot at the scenario's
start (a robot of parts as its description composes it, `part_directives`: a model
instance per part, welded, and our frames), the furniture and the dishes welded to the
world. Drake's own types (`ModelDirectives`, `yaml_dump_typed`) write the file, so Drake
reads it back as it was meant:

    ROS_PACKAGE_PATH=DIR python -m pydrake.visualization.model_visualizer DIR/NAME.dmd.yaml
"""

import re
import shutil
from dataclasses import replace
from pathlib import Path

from pydrake.common.schema import Transform
from pydrake.common.yaml import yaml_dump_typed
from pydrake.multibody.parsing import AddModel, AddWeld, ModelDirective, ModelDirectives
from pydrake.multibody.plant import MultibodyPlant

from s3o_drake.world.builder import FLOOR_RGBA, WALL_RGBA, fixed_models, room_boxes
from s3o_drake.world.contents import SceneContents
from s3o_drake.world.resources import PACKAGE_NAME, make_parser, package_file
from s3o_drake.world.robot import Robot
from s3o_drake.world.robot_description import part_directives

ROBOT_INSTANCE = "robot"
ROOM_INSTANCE = "room"

_FOLDERS = {"table": "tables", "chair": "chairs", "dish": "dishes"}
_PACKAGE_XML = """<?xml version="1.0"?>
<package format="2">
  <name>{name}</name>
  <version>0.1.0</version>
  <description>A scene of s3o_drake as Drake model directives ({directives}).</description>
  <maintainer email="s3o-drake@example.com">s3o_drake developers</maintainer>
  <license>BSD-3-Clause</license>
</package>
"""


def package_name(name: str) -> str:
    """The package a scene called `name` is written as: `s3o_` and its name, in the
    letters a package name may hold."""
    return "s3o_" + re.sub(r"[^a-z0-9_]", "_", name.lower())


def room_sdf(contents: SceneContents) -> str:
    """The room's floor (seen only) and walls (seen and collided with) as one static
    SDFormat model, in W."""
    parts = []
    for name, (p, size) in room_boxes(contents.room, contents.floor_margin).items():
        rgba = " ".join(f"{c:g}" for c in (FLOOR_RGBA if name == "floor" else WALL_RGBA))
        pose = f"<pose>{p[0]:.6g} {p[1]:.6g} {p[2]:.6g} 0 0 0</pose>"
        box = f"<geometry><box><size>{size[0]:.6g} {size[1]:.6g} {size[2]:.6g}</size></box>" \
              "</geometry>"
        parts.append(f'      <visual name="{name}">{pose}{box}'
                     f"<material><diffuse>{rgba}</diffuse></material></visual>")
        if name != "floor":
            parts.append(f'      <collision name="{name}">{pose}{box}</collision>')
    body = "\n".join(parts)
    return (f'<?xml version="1.0"?>\n<sdf version="1.9">\n  <model name="{ROOM_INSTANCE}">\n'
            f"    <static>true</static>\n    <link name=\"{ROOM_INSTANCE}\">\n{body}\n"
            "    </link>\n  </model>\n</sdf>\n")


def scene_directives(contents: SceneContents, package: str) -> tuple[
        ModelDirectives, dict[str, str | Path]]:
    """The directives of `contents` and the model files they name ({path in the package:
    text, or the Path of a file to copy}; a single-instance robot's URDF is not among
    them: it is copied)."""
    url = f"package://{package}"
    robot = contents.robot
    q0 = robot.positions(*contents.start)
    if robot.is_of_parts:
        directives, files = _parts_directives(robot, q0, package)
    else:
        directives = [ModelDirective(add_model=AddModel(
            name=ROBOT_INSTANCE, file=f"{url}/robot/{robot.model_file.name}",
            default_joint_positions={j: [float(q)] for j, q in zip(robot.joints, q0,
                                                                     strict=True)}))]
        files = {}
    directives.append(ModelDirective(add_model=AddModel(name=ROOM_INSTANCE,
                                                        file=f"{url}/room.sdf")))
    files["room.sdf"] = room_sdf(contents)
    for fixed in fixed_models(contents):
        path = f"{_FOLDERS[fixed.body]}/{fixed.name}.sdf"
        files[path] = fixed.sdf
        directives.append(ModelDirective(add_model=AddModel(name=fixed.name,
                                                            file=f"{url}/{path}")))
        directives.append(ModelDirective(add_weld=AddWeld(
            parent="world", child=f"{fixed.name}::{fixed.body}", X_PC=Transform(fixed.X_WB))))
    return ModelDirectives(directives=directives), files


_OUR_URL = re.compile(rf"package://{PACKAGE_NAME}/([^\"'<>\s]+)")


def _parts_directives(robot: Robot, q0, package: str) -> tuple[list[ModelDirective],
                                                               dict[str, str | Path]]:
    """A robot of parts' directives (`part_directives`, its model files under the scene's
    package) with its joints at `q0` (`Robot.joints` order; each default on the part that
    holds the joint), and the files they need: {path in the package: text of a part's
    model with its URLs moved into the package, or the Path of a mesh to copy}."""
    files: dict[str, str | Path] = {}

    def moved(url: str) -> str:
        """`url` under the scene's package, its file (and what it names) to be written."""
        path = _OUR_URL.fullmatch(url).group(1)
        if f"robot/{path}" not in files:
            if path.endswith((".urdf", ".sdf", ".xml")):
                text = package_file(url).read_text()
                files[f"robot/{path}"] = text  # before the recursion: a cycle ends
                for named in sorted(set(_OUR_URL.findall(text))):
                    moved(f"package://{PACKAGE_NAME}/{named}")
                files[f"robot/{path}"] = _OUR_URL.sub(rf"package://{package}/robot/\1", text)
            else:
                files[f"robot/{path}"] = package_file(url)
        return f"package://{package}/robot/{path}"

    description = robot.description
    description = replace(description, parts=[replace(p, model=moved(p.model))
                                              for p in description.parts])
    # Which part holds each joint: the robot parsed as the builder parses it.
    plant = MultibodyPlant(0.0)
    placed = robot.add_model_instances(make_parser(plant), name=ROBOT_INSTANCE)
    defaults: dict[str, dict[str, list[float]]] = {}
    for name, q in zip(robot.joints, q0, strict=True):
        joint = placed.joint(name)
        part = plant.GetModelInstanceName(joint.model_instance())
        defaults.setdefault(part, {})[joint.name()] = [float(q)]
    directives = list(part_directives(description, ROBOT_INSTANCE).directives)
    for directive in directives:
        if directive.add_model is not None:
            model = directive.add_model
            model.default_joint_positions = defaults.get(model.name, {})
    return directives, files


def write_directives(contents: SceneContents, out: Path, name: str) -> Path:
    """Writes the scene of `contents` as a package in `out` (created; files of an earlier
    export there are replaced) and returns its `<name>.dmd.yaml`."""
    package = package_name(name)
    directives, files = scene_directives(contents, package)
    dmd = out / f"{name}.dmd.yaml"
    out.mkdir(parents=True, exist_ok=True)
    (out / "package.xml").write_text(_PACKAGE_XML.format(name=package, directives=dmd.name))
    (out / "robot").mkdir(exist_ok=True)
    if not contents.robot.is_of_parts:
        model = contents.robot.model_file
        shutil.copyfile(model, out / "robot" / model.name)
    for path, text in files.items():
        (out / path).parent.mkdir(parents=True, exist_ok=True)
        if isinstance(text, Path):
            shutil.copyfile(text, out / path)
        else:
            (out / path).write_text(text)
    dmd.write_text(yaml_dump_typed(directives))
    return dmd
