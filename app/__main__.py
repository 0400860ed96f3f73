"""``python -m app``: the Robotics II Lab command line (``serve`` when no command is given)."""
import sys

from app.cli import main

sys.exit(main())
