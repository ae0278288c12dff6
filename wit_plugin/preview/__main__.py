"""``python -m wit_plugin.preview``: see ``main``."""
import sys

from . import main

sys.exit(main())
