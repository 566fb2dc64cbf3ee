"""``python -m codermind`` names the command line: it lives one layer up, in
``codermind_cli`` (the plugin package does not import it)."""

import sys

print("codermind: the command line is `codermind` (or `python -m codermind_cli`); the "
      "package codermind holds the Mitsuba plugins", file=sys.stderr)
sys.exit(2)
