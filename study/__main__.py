"""``python -m study`` runs the ``geardyn`` command line."""
import sys

from study.cli import main

sys.exit(main())
