"""Keep numba's on-disk cache consistent with the sources it was compiled from.

numba's ``cache=True`` invalidates a cached function only when *its own* source file
changes. Our kernels inline functions from other modules (the dispatching integrator inlines
every plant's right-hand side and its laws; observation kernels read plant constants), so an
edited plant file would otherwise be silently ignored by a stale cached kernel. Before the
first kernel runs -- when the first env (single or vector) is made, at the first
``hydro_envs.sim.simulate`` call and when a ``hydro`` command starts, not on import --
:func:`ensure_fresh_cache` fingerprints every source file of ``hydro_envs`` and
``identification`` (path, size, mtime) and, when the fingerprint differs from the one stored
beside the cache, deletes the package's numba cache files so everything recompiles from the
current sources. Once per process; cost: one ``stat`` per file. Code that calls a law's compiled
function directly, before any of those, may load a kernel cached from older sources.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

_ROOTS = ("hydro_envs", "identification")
_STAMP = "numba-sources.sha256"
_checked = False


def _package_dirs() -> list[Path]:
    base = Path(__file__).resolve().parent.parent
    return [base / name for name in _ROOTS if (base / name).is_dir()]


def sources_fingerprint() -> str:
    h = hashlib.sha256()
    for root in _package_dirs():
        for path in sorted(root.rglob("*.py")):
            st = path.stat()
            h.update(f"{path.relative_to(root.parent)}:{st.st_size}:{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def purge_stale_numba_cache() -> bool:
    """Delete this project's numba cache files if any source changed; return True if purged."""
    if os.environ.get("NUMBA_CACHE_DIR") or os.environ.get("NUMBA_DISABLE_JIT"):
        return False  # a custom cache location or no JIT: not ours to manage
    dirs = _package_dirs()
    if not dirs:
        return False
    stamp = dirs[0] / "__pycache__" / _STAMP
    digest = sources_fingerprint()
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    for root in dirs:
        for cache_file in list(root.rglob("__pycache__/*.nbi")) + list(root.rglob("__pycache__/*.nbc")):
            try:
                cache_file.unlink()
            except OSError:
                pass
    try:
        stamp.parent.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:  # read-only install: numba falls back to its own cache locator
        pass
    return True


def ensure_fresh_cache() -> bool:
    """:func:`purge_stale_numba_cache`, once per process (later calls return False at once)."""
    global _checked
    if _checked:
        return False
    _checked = True
    return purge_stale_numba_cache()
