"""Make ``exotune`` (project root) and the test helpers (``tests/``) importable without install."""

import os
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))
_ROOT = os.path.dirname(_HERE)
for _p in (_ROOT, _HERE):
    if _p not in sys.path:
        sys.path.insert(0, _p)

# Property tests run a fixed, reproducible set of examples (CI must not depend on the draw);
# set HYPOTHESIS_PROFILE=explore to search with fresh random examples instead.
from hypothesis import settings as _hsettings  # noqa: E402

_hsettings.register_profile("exotune", derandomize=True, deadline=None, print_blob=True)
_hsettings.register_profile("explore", derandomize=False, deadline=None, print_blob=True)
_hsettings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "exotune"))
