"""ln record | play | bag info | bag convert: recordings, implemented by the
ln_bag package (MCAP files that ROS 2 tools read). Without ln_bag the commands
exist and say what is missing."""

from .common import CliError

COMMANDS = ("record", "play", "bag")


def register(groups, common):
    try:
        from ln_bag import cli
    except ImportError as error:
        missing = str(error)

        def run(session):
            raise CliError(
                "recordings need the ln_bag package (%s)" % missing,
                "build it: colcon build --packages-select ln_bag, then source install/setup.bash",
            )

        for name in COMMANDS:
            p = groups.add_parser(name, parents=[common], help="(needs the ln_bag package)", add_help=True)
            p.add_argument("arguments", nargs="*")
            # whatever options follow (ln bag convert A B --overwrite): the answer is what is missing
            p.set_defaults(run=run, any_arguments=True)
        return
    cli.register(groups, common)
