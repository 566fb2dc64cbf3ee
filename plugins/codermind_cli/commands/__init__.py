"""Sub-commands of ``codermind``: each module defines NAME, HELP, add_arguments(parser), run(args)."""
