"""joshua-mjx's tests import their helpers (pick_place_script.py) from this folder."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
