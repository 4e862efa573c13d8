"""Write a scenario as Drake model directives, which Drake's own tools open.

    s3o directives SCENARIO [--out DIR] [--set PATH=VALUE ...]

DIR (default out/directives/<scenario's name>) becomes a package: package.xml, NAME.dmd.yaml,
the robot's URDF and an SDFormat file per table, chair and dish, placed where the simulation
places them (the true world: every chair, every object, the robot at its start). To look at
it, or to load it into a plant of your own:

    ROS_PACKAGE_PATH=DIR python -m pydrake.visualization.model_visualizer DIR/NAME.dmd.yaml

    parser = Parser(plant); parser.package_map().AddPackageXml("DIR/package.xml")
    ProcessModelDirectives(LoadModelDirectives("DIR/NAME.dmd.yaml"), plant, parser)
"""

import sys
from pathlib import Path

# Light imports only: the heavy ones come after the arguments are parsed.
from s3o_drake.commands.common import command_parser, read_scenario
from s3o_drake.commands.options import add_out, add_overrides, out_folder, with_overrides_or_fail


def main(argv: list[str] | None = None) -> int:
    parser = command_parser("directives", __doc__)
    parser.add_argument("scenario", metavar="SCENARIO", help="the scenario file (YAML)")
    add_out(parser, file=False, note="default out/directives/<the scenario's name>")
    add_overrides(parser, "replace a scenario field before writing (as `s3o run --set`)")
    args = parser.parse_args(argv)
    scenario = with_overrides_or_fail(read_scenario(args.scenario), args.overrides)
    name = Path(args.scenario).name.removesuffix(".yaml").removesuffix(".yml")
    out = out_folder(args.out or Path("out") / "directives" / name)

    from s3o_drake.world.directives import write_directives

    dmd = write_directives(scenario.contents, out, name)
    print(f"wrote {dmd} and the models it names ({out}/package.xml is their package)")
    print(f"look at it: ROS_PACKAGE_PATH={out} python -m pydrake.visualization.model_visualizer "
          f"{dmd}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
