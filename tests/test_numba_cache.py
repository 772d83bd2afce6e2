"""The stale-cache guard: numba cache files are deleted exactly when a source file changed."""

from __future__ import annotations

import os

from hydro_envs import _numba_cache


def test_purges_only_when_sources_change(tmp_path, monkeypatch):
    pkg = tmp_path / "hydro_envs"
    (pkg / "__pycache__").mkdir(parents=True)
    src = pkg / "plant.py"
    src.write_text("x = 1\n")
    monkeypatch.setattr(_numba_cache, "_package_dirs", lambda: [pkg])
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    cached = pkg / "__pycache__" / "kernels.step-1.py311.nbi"

    cached.write_text("index")
    assert _numba_cache.purge_stale_numba_cache() is True  # first run: no stamp yet
    assert not cached.exists()

    cached.write_text("index")
    assert _numba_cache.purge_stale_numba_cache() is False  # nothing changed: cache kept
    assert cached.exists()

    src.write_text("x = 2  # edited plant\n")
    st = src.stat()
    os.utime(src, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000))
    assert _numba_cache.purge_stale_numba_cache() is True  # edit: stale kernels removed
    assert not cached.exists()
