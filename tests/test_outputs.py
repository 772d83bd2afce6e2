"""Writing outputs (hydro_envs.outputs): atomic files, staged result sets, output-target checks."""

from __future__ import annotations

import errno

import numpy as np
import pytest

from hydro_envs import outputs
from hydro_envs.outputs import OutputError, Staged, atomic_path, atomic_write, check_output_dir, check_output_file


def _full_disk(monkeypatch, after: int = 0):
    """Make every ``open(..., 'wb')`` of a temporary output file fail with ENOSPC after ``after`` bytes."""
    import builtins

    real = builtins.open

    class Full:
        def __init__(self, fh):
            self.fh, self.n = fh, 0

        def write(self, b):
            self.n += len(b)
            if self.n > after:
                raise OSError(errno.ENOSPC, "No space left on device")
            return self.fh.write(b)

        def __getattr__(self, name):
            return getattr(self.fh, name)

        def __enter__(self):
            return self

        def __exit__(self, *a):
            self.fh.close()

    def fake(file, mode="r", *a, **k):
        fh = real(file, mode, *a, **k)
        return Full(fh) if ("w" in mode and ".tmp" in str(file)) else fh

    monkeypatch.setattr(builtins, "open", fake)


def _files(d):
    return sorted(p.name for p in d.iterdir())


def test_atomic_write_replaces_whole_and_leaves_no_temp(tmp_path):
    p = tmp_path / "a.md"
    atomic_write(p, "old\n")
    atomic_write(p, "new\n")
    assert p.read_text() == "new\n" and _files(tmp_path) == ["a.md"]


def test_full_disk_is_an_error_naming_the_file_and_keeps_the_old_one(tmp_path, monkeypatch):
    p = tmp_path / "a.md"
    p.write_text("old\n")
    _full_disk(monkeypatch)
    with pytest.raises(OSError) as e:
        atomic_write(p, "new text that does not fit\n")
    assert e.value.errno == errno.ENOSPC and f"cannot write {p}" in str(e.value) and "No space" in str(e.value)
    assert p.read_text() == "old\n" and _files(tmp_path) == ["a.md"]


def test_atomic_path_keeps_the_suffix_for_writers_that_need_it(tmp_path):
    p = tmp_path / "stats.npz"
    with atomic_path(p) as tmp:
        assert tmp.name.endswith(".tmp.npz") and tmp.name.startswith(".stats.")
        np.savez(tmp, a=np.arange(3))
    assert np.load(p)["a"].tolist() == [0, 1, 2] and _files(tmp_path) == ["stats.npz"]
    with pytest.raises(RuntimeError):
        with atomic_path(tmp_path / "x.npz") as tmp:
            np.savez(tmp, a=1)
            raise RuntimeError("writer failed")
    assert _files(tmp_path) == ["stats.npz"]


def test_staged_files_are_committed_together_or_not_at_all(tmp_path, monkeypatch):
    with Staged(tmp_path) as st:
        st.write("a.md", "a\n")
        st.write("b.json", "{}\n")
        assert _files(tmp_path) != ["a.md", "b.json"]  # nothing in place before the commit
    assert _files(tmp_path) == ["a.md", "b.json"]
    out = tmp_path / "full"
    _full_disk(monkeypatch, after=10)
    with pytest.raises(OSError, match=r"cannot write .*c\.csv: No space left"):
        with Staged(out) as st:
            st.write("a.md", "a\n")
            st.write("c.csv", "x" * 100)
    assert _files(out) == []  # no complete-looking .md beside a missing .csv


def test_output_file_checks(tmp_path):
    inp = tmp_path / "in.csv"
    inp.write_text("x\n")
    with pytest.raises(OutputError, match="is the input file"):
        check_output_file(inp, inputs=[inp], force=True)
    with pytest.raises(OutputError, match="is the input file"):
        check_output_file(tmp_path / "." / "in.csv", inputs=[str(inp)], force=True)
    with pytest.raises(OutputError, match=r"suffix '\.xlsx' is not written; allowed \.csv, \.parquet"):
        check_output_file(tmp_path / "r.xlsx", suffixes=(".csv", ".parquet"))
    with pytest.raises(OutputError, match="the file exists; pass --force"):
        check_output_file(inp)
    assert check_output_file(inp, force=True) == inp
    assert check_output_file(tmp_path / "new.csv", inputs=[inp], suffixes=(".csv",)) == tmp_path / "new.csv"
    with pytest.raises(OutputError, match="is a folder"):
        check_output_file(tmp_path, force=True)


def test_output_dir_checks(tmp_path):
    (tmp_path / "f.txt").write_text("x")
    with pytest.raises(OutputError, match="is a file, not a folder"):
        check_output_dir(tmp_path / "f.txt", force=True)
    with pytest.raises(OutputError, match="not empty; pass --force"):
        check_output_dir(tmp_path)
    assert check_output_dir(tmp_path, force=True) == tmp_path
    assert check_output_dir(tmp_path / "new") == tmp_path / "new"
    (tmp_path / "empty").mkdir()
    assert check_output_dir(tmp_path / "empty") == tmp_path / "empty"
    with pytest.raises(OutputError, match="holds the input file"):
        check_output_dir(tmp_path, force=True, inputs=[tmp_path / "f.txt"])
    assert issubclass(OutputError, ValueError) and outputs.write_failed("f", OSError(28, "full")).errno == 28
