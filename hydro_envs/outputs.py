"""Writing output files so that nothing is lost or left half written.

* :func:`check_output_file` / :func:`check_output_dir`: an output target checked before the work
  starts: never one of the command's input files, a file output's suffix among those allowed,
  and an existing file or a non-empty folder refused unless ``force`` (:class:`OutputError`, a
  ``ValueError``: the CLI exits 2).
* :func:`atomic_write` (text or bytes) and :func:`atomic_path` (a temporary path for a library
  that writes the file itself: numpy, torch, matplotlib, pyarrow): the data go to a hidden
  temporary file beside the target, ``.<name>.<random>.tmp<suffix>``, which is flushed, synced
  and renamed onto the target (``os.replace``, atomic on one file system). A failed write (a
  full disk: ``ENOSPC``) removes the temporary file and raises ``OSError`` naming the target; the
  target is either the complete old file, the complete new one, or absent.
* :class:`Staged`: several files of one result (a benchmark's tables, a diagnosis report) written
  to temporary files and renamed only when every one of them was written; on a failure none is
  renamed (a failure while renaming puts back the files already replaced) and every temporary
  file is removed.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, Literal

__all__ = ["OutputError", "check_output_file", "check_output_dir", "atomic_write", "atomic_path", "Staged",
           "write_failed"]


class OutputError(ValueError):
    """An output target that would overwrite an input or an earlier result, or has a wrong suffix."""


def _same(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return a.resolve() == b.resolve()


def _refuse_inputs(path: Path, inputs: Iterable[Any], flag: str) -> None:
    for inp in inputs:
        if inp is None:
            continue
        q = Path(inp)
        if _same(path, q) or path.resolve() == q.resolve():
            raise OutputError(f"{flag} {path}: is the input file {q}; an input is never overwritten, "
                              "choose another output file")


def check_output_file(path: Any, *, flag: str = "--out", inputs: Iterable[Any] = (), force: bool = False,
                      suffixes: tuple[str, ...] | None = None) -> Path:
    """``path`` as a :class:`~pathlib.Path` fit to be written: not one of ``inputs`` (even with
    ``force``), its suffix in ``suffixes`` (when given), not an existing folder, and not an
    existing file unless ``force``."""
    p = Path(path)
    _refuse_inputs(p, inputs, flag)
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise OutputError(f"{flag} {p}: suffix {p.suffix or '(none)'!r} is not written; allowed {', '.join(suffixes)}")
    if p.is_dir():
        raise OutputError(f"{flag} {p}: is a folder; give a file name")
    if p.exists() and not force:
        raise OutputError(f"{flag} {p}: the file exists; pass --force to replace it (or choose another name)")
    if p.parent.exists() and not p.parent.is_dir():
        raise OutputError(f"{flag} {p}: {p.parent} is not a folder")
    return p


def check_output_dir(path: Any, *, flag: str = "--out", inputs: Iterable[Any] = (), force: bool = False) -> Path:
    """``path`` as a folder fit to be written into: not an existing file, no input file inside it
    when it is replaced, and empty (or absent) unless ``force``."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise OutputError(f"{flag} {p}: is a file, not a folder; give a folder (it is created)")
    if p.is_dir():
        root = p.resolve()
        for inp in inputs:
            if inp is not None and root in Path(inp).resolve().parents:
                raise OutputError(f"{flag} {p}: holds the input file {inp}; an input is never overwritten, choose "
                                  "another folder")
    if p.is_dir() and any(p.iterdir()) and not force:
        raise OutputError(f"{flag} {p}: the folder is not empty; pass --force to write into it (files of the "
                          "same name are replaced) or choose a new folder")
    return p


def write_failed(path: Any, exc: OSError) -> OSError:
    """The ``OSError`` of a failed write of ``path``: its errno, a message naming the file."""
    why = exc.strerror or str(exc)
    return OSError(exc.errno or errno.EIO, f"cannot write {path}: {why}; nothing was written to it")


def _temp_name(target: Path) -> tuple[int, Path]:
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=".tmp" + target.suffix, dir=target.parent)
    return fd, Path(name)


def _commit(tmp: Path, target: Path) -> None:
    with contextlib.suppress(OSError):  # not every file system syncs a file opened read-only
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    os.replace(tmp, target)


@contextlib.contextmanager
def atomic_path(path: Any) -> Iterator[Path]:
    """A temporary path beside ``path`` (same suffix) to write to; renamed onto ``path`` when the
    block ends without an error, removed otherwise (an ``OSError`` is re-raised naming ``path``)."""
    target = Path(path)
    fd, tmp = _temp_name(target)
    os.close(fd)
    try:
        yield tmp
        _commit(tmp, target)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise write_failed(target, exc) from None
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def atomic_write(path: Any, data: str | bytes, *, encoding: str = "utf-8") -> Path:
    """Write ``data`` (``str``: encoded with ``encoding``) to ``path`` atomically; return the path."""
    target = Path(path)
    payload = data.encode(encoding) if isinstance(data, str) else bytes(data)
    with atomic_path(target) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(payload)
    return target


class Staged:
    """Files of one result, committed together: ``stage.path(name)`` gives the temporary path of
    ``folder / name`` to write; :meth:`commit` renames every one of them onto its target. Used as
    a context manager, a block that raises removes every temporary file and renames none (an
    ``OSError`` is re-raised naming the file being written)."""

    def __init__(self, folder: Any) -> None:
        self.folder = Path(folder)
        self._files: list[tuple[Path, Path]] = []
        self._current: Path | None = None

    def path(self, name: str) -> Path:
        target = self.folder / name
        fd, tmp = _temp_name(target)
        os.close(fd)
        self._files.append((tmp, target))
        self._current = target
        return tmp

    def write(self, name: str, data: str | bytes, *, encoding: str = "utf-8") -> Path:
        tmp = self.path(name)
        with open(tmp, "wb") as fh:
            fh.write(data.encode(encoding) if isinstance(data, str) else bytes(data))
        return self.folder / name

    def commit(self) -> list[Path]:
        """Rename every temporary file onto its target. A failure part way puts back what was
        there before (the files it replaced are kept aside until every rename succeeded)."""
        done: list[tuple[Path, Path | None]] = []
        try:
            for tmp, target in self._files:
                self._current = target
                backup = None
                if target.exists():
                    fd, name = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=".bak" + target.suffix,
                                                dir=target.parent)
                    os.close(fd)
                    backup = Path(name)
                    os.replace(target, backup)
                done.append((target, backup))
                _commit(tmp, target)
        except OSError:
            for target, backup in reversed(done):
                with contextlib.suppress(OSError):
                    if backup is not None:
                        os.replace(backup, target)
                    else:
                        target.unlink(missing_ok=True)
            raise
        for _, backup in done:
            if backup is not None:
                with contextlib.suppress(OSError):
                    backup.unlink()
        self._files = []
        return [target for target, _ in done]

    def discard(self) -> None:
        for tmp, _ in self._files:
            with contextlib.suppress(OSError):
                tmp.unlink()
        self._files = []

    def __enter__(self) -> "Staged":
        return self

    def __exit__(self, typ: Any, exc: Any, tb: Any) -> Literal[False]:
        if exc is None:
            try:
                self.commit()
            except OSError as e:
                self.discard()
                raise write_failed(self._current, e) from None
            return False
        self.discard()
        if isinstance(exc, OSError):
            raise write_failed(self._current or self.folder, exc) from None
        return False
