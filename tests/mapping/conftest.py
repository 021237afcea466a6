"""amr_mapping.slam is written beside the nodes: until it lands, the node tests run on tests/mapping/fake_slam.py."""

import importlib.util
import sys
from pathlib import Path

if importlib.util.find_spec("amr_mapping.slam") is None:
    sys.path.insert(0, str(Path(__file__).parent))
    import fake_slam

    sys.modules["amr_mapping.slam"] = fake_slam
