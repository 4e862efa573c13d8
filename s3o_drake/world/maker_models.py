"""A part of a robot as its maker ships it (a xacro file and its meshes), turned into a URDF
that Drake reads: the build step of a robot of parts (`s3o build robot NAME --steps model`).

The maker's files stay unchanged under ``models/parts/<maker's folder>/`` (with their
license and SOURCE.md); what this module writes is ours and reproducible, in the robot's
``generated/`` folder:

- the xacro expanded (the `xacro` package from PyPI; its ``$(find pkg)`` is answered from
  the ROS packages under models/parts/, as ROS's ament index would);
- every mesh that Drake cannot use for collision converted to Wavefront OBJ (the `trimesh`
  library; COLLADA through `pycollada`): Drake 1.51's convex hulls, which its collision
  queries use for meshes, read only .obj, .vtk and .gltf, and a maker's COLLADA (.dae) or
  STL files are refused;
- a ``<transmission>`` with Drake's PD gains for each joint the robot actuates, which the
  maker's description leaves to its ROS controllers;
- optionally each link drawn with its collision geometry, for a part whose visual meshes
  are not shipped (to keep the repository small).

The generated URDF names its meshes as ``package://s3o_drake/<robot>/generated/...``, so
that loading the robot needs neither xacro nor trimesh; only building it does (the
``robots`` extra of pyproject.toml).
"""

import contextlib
import copy
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from s3o_drake.world.resources import MODELS_DIR, PACKAGE_NAME, package_file

PARTS_DIR = MODELS_DIR / "parts"
"""The makers' files, unchanged: one folder per maker's repository, holding its ROS
packages (each a folder with a package.xml) and its LICENSE and SOURCE.md."""
DRAKE_MESHES = (".obj", ".vtk", ".gltf")
"""The mesh files Drake 1.51 makes convex hulls of (its collision geometry for meshes)."""


@dataclass(frozen=True)
class Gains:
    """PD gains of a joint's actuator (Drake's `<drake:controller_gains>`)."""

    joint: str
    p: float
    d: float


def ros_packages(root: Path = PARTS_DIR) -> dict[str, Path]:
    """The ROS packages under `root`: {name in package.xml: its folder}."""
    packages = {}
    for xml in sorted(root.glob("**/package.xml")):
        name = ET.parse(xml).getroot().findtext("name", "").strip()
        if name:
            packages[name] = xml.parent
    return packages


@contextlib.contextmanager
def _find_packages(packages: dict[str, Path]):
    """xacro's ``$(find pkg)`` asks ROS's ament index; here it is answered from
    `packages` (xacro reads it through this one function)."""
    from xacro import substitution_args

    def find(pkg: str) -> str:
        if pkg not in packages:
            raise KeyError(f"no ROS package {pkg!r} under models/parts/ "
                           f"(known: {', '.join(sorted(packages))})")
        return str(packages[pkg])

    saved = substitution_args._eval_find
    substitution_args._eval_find = find
    try:
        yield
    finally:
        substitution_args._eval_find = saved


def expand_xacro(path: Path, packages: dict[str, Path] | None = None) -> str:
    """The URDF text of a xacro file, its ``$(find pkg)`` resolved in `packages` (default:
    those under models/parts/)."""
    import xacro

    packages = ros_packages() if packages is None else packages
    with _find_packages(packages):
        document = xacro.process_file(str(path))
    return document.toprettyxml(indent="  ")


def _mesh_file(url: str, packages: dict[str, Path]) -> tuple[str, Path]:
    """(package, path inside it) and the file of a `package://` mesh URL."""
    prefix = "package://"
    if not url.startswith(prefix):
        raise ValueError(f"mesh {url!r}: expected a package:// URL")
    package, _, inside = url[len(prefix):].partition("/")
    if package == PACKAGE_NAME:
        return inside, package_file(url)
    if package not in packages:
        raise ValueError(f"mesh {url!r}: no ROS package {package!r} under models/parts/")
    return f"{package}/{inside}", packages[package] / inside


def convert_mesh(source: Path, target: Path) -> None:
    """Writes `source` (any mesh trimesh reads: COLLADA, STL, ...) as a Wavefront OBJ,
    its scene's transforms applied (one mesh, metres as the source gives them)."""
    import trimesh

    mesh = trimesh.load(source, force="mesh")
    target.parent.mkdir(parents=True, exist_ok=True)
    # Micrometres (digits=6) are finer than the parts are made; no material file (Drake
    # draws the URDF's material, or its default). Normals are written: Drake's VTK render
    # engine (the overhead camera's) refuses an OBJ without them.
    target.write_text(mesh.export(file_type="obj", include_normals=True, digits=6,
                                  include_texture=False, write_texture=False))


def _visuals_from_collisions(robot: ET.Element) -> None:
    for link in robot.iter("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
        for collision in link.findall("collision"):
            visual = copy.deepcopy(collision)
            visual.tag = "visual"
            link.append(visual)


def _add_transmissions(robot: ET.Element, gains: list[Gains]) -> None:
    ET.register_namespace("drake", "http://drake.mit.edu")
    joints = {j.get("name"): j for j in robot.iter("joint")}
    for g in gains:
        joint = joints.get(g.joint)
        if joint is None:
            raise ValueError(f"actuators: the model has no joint {g.joint!r}")
        if joint.find("mimic") is not None:
            raise ValueError(f"actuators: {g.joint!r} mimics another joint; actuate that one")
        transmission = ET.SubElement(robot, "transmission", name=f"{g.joint}_trans")
        ET.SubElement(transmission, "type").text = \
            "transmission_interface/SimpleTransmission"
        ET.SubElement(transmission, "joint", name=g.joint)
        actuator = ET.SubElement(transmission, "actuator", name=f"{g.joint}_motor")
        ET.SubElement(actuator, "{http://drake.mit.edu}controller_gains",
                      p=repr(float(g.p)), d=repr(float(g.d)))


def build_part(xacro_file: Path, out: Path, *, mesh_dir: Path, gains: list[Gains] = (),
               visuals_from_collision: bool = False,
               packages: dict[str, Path] | None = None) -> list[Path]:
    """Writes the URDF `out` from the maker's xacro (see the module docstring), its meshes
    converted into `mesh_dir` (inside models/, named by package:// URLs). Returns the
    files written, `out` first."""
    packages = ros_packages() if packages is None else packages
    xacro_file, out, mesh_dir = (Path(p).resolve() for p in (xacro_file, out, mesh_dir))
    robot = ET.fromstring(expand_xacro(xacro_file, packages))
    if visuals_from_collision:
        _visuals_from_collisions(robot)
    written = [out]
    converted: dict[str, str] = {}
    for mesh in robot.iter("mesh"):
        url = mesh.get("filename", "")
        if url not in converted:
            inside, source = _mesh_file(url, packages)
            if source.suffix.lower() in DRAKE_MESHES:
                converted[url] = url
            else:
                target = (mesh_dir / inside).with_suffix(".obj")
                convert_mesh(source, target)
                written.append(target)
                converted[url] = (f"package://{PACKAGE_NAME}/"
                                  f"{target.relative_to(MODELS_DIR).as_posix()}")
        mesh.set("filename", converted[url])
    _add_transmissions(robot, list(gains))
    ET.indent(robot, space="  ")
    header = (f"<!-- Generated by s3o_drake (world/maker_models.py) from "
              f"{xacro_file.relative_to(MODELS_DIR).as_posix()}: do not edit; "
              f"`s3o build robot` writes it again. -->\n")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text('<?xml version="1.0"?>\n' + header
                   + ET.tostring(robot, encoding="unicode") + "\n")
    return written


def generated_dir(robot_folder: Path) -> Path:
    """Where a robot's parts are built: ``models/<robot>/generated/``."""
    return robot_folder / "generated"


def build_parts(description, robot_folder: Path) -> list[Path]:
    """Builds every part of a robot's description (`RobotDescription`) that names a xacro
    into its generated folder, which is emptied first (what an earlier build wrote and
    this one does not is gone). Returns the files written."""
    import shutil

    out = generated_dir(Path(robot_folder).resolve())
    if out.is_dir():
        shutil.rmtree(out)
    packages = ros_packages()
    written = []
    for part in description.parts:
        if not part.xacro:
            continue
        target = package_file(part.model)
        if not target.resolve().is_relative_to(out):
            raise ValueError(f"part {part.name}: its model {part.model} must be in "
                             f"{out.relative_to(MODELS_DIR)}/, where the build writes")
        gains = [Gains(a.joint, a.p, a.d) for a in part.actuators]
        written += build_part(package_file(part.xacro), target, mesh_dir=out / "meshes",
                              gains=gains, visuals_from_collision=part.visuals_from_collision,
                              packages=packages)
    return written
