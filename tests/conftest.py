"""Make ``exotune`` (project root) and the test helpers (``tests/``) importable without install."""

import os
import sys

_HERE = os.path.dirname(os.path.abspath(__file__))
_ROOT = os.path.dirname(_HERE)
for _p in (_ROOT, _HERE):
    if _p not in sys.path:
        sys.path.insert(0, _p)

# Python's bytecode caches stay on for the suite even where the environment turns them off
# (PYTHONDONTWRITEBYTECODE, set in many container images): without them every xdist worker rewrites
# the assertions of every test module again at collection (about half a minute of CPU per worker)
# and every command a test starts compiles exotune's modules again. The caches are written beside
# the sources (``__pycache__``, ignored by git), as numba's kernel cache is;
# EXOTUNE_TEST_NO_BYTECODE=1 keeps the environment's choice.
if os.environ.get("PYTHONDONTWRITEBYTECODE") and not os.environ.get("EXOTUNE_TEST_NO_BYTECODE"):
    del os.environ["PYTHONDONTWRITEBYTECODE"]  # the workers and the commands tests start inherit it
    sys.dont_write_bytecode = False

# Property tests run a fixed, reproducible set of examples (CI must not depend on the draw);
# set HYPOTHESIS_PROFILE=explore to search with fresh random examples instead.
from hypothesis import settings as _hsettings  # noqa: E402

_hsettings.register_profile("exotune", derandomize=True, deadline=None, print_blob=True)
_hsettings.register_profile("explore", derandomize=False, deadline=None, print_blob=True)
_hsettings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "exotune"))


def pytest_configure(config):
    """Under ``pytest -n`` (the README's test command), fill numba's kernel cache once, in two
    processes side by side, before the workers start (tests/warm_kernels.py); skipped in the
    workers themselves, without xdist, on the numpy engine and with EXOTUNE_TEST_NO_WARM=1."""
    import subprocess
    import time

    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    if os.environ.get("EXOTUNE_NUMPY_ONLY") or os.environ.get("EXOTUNE_TEST_NO_WARM"):
        return
    t0 = time.monotonic()
    script = os.path.join(_HERE, "warm_kernels.py")
    procs = [subprocess.Popen([sys.executable, script, part], cwd=_ROOT, stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE) for part in ("continuous", "sampled")]
    failed = []
    for part, p in zip(("continuous", "sampled"), procs):
        try:
            _out, err = p.communicate(timeout=1200)
        except subprocess.TimeoutExpired:
            p.kill()
            _out, err = p.communicate()
        if p.returncode:
            failed.append(f"{part}: {err.decode(errors='replace').strip().splitlines()[-1:] or p.returncode}")
    sys.stderr.write(f"numba kernel cache warmed in {time.monotonic() - t0:.0f} s"
                     + (f" (not all: {'; '.join(failed)}; the rest compiles when used)" if failed else "") + "\n")
