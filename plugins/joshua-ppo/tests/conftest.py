"""joshua-ppo's tests import their test task (distributed_worker.py's slider) from this folder."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
