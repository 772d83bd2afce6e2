"""The error convention of every ``hydro`` subcommand.

One line on stderr, never a traceback::

    hydro <command>: error: <file>: <field> = <value>; allowed <range>

and the exit code says what happened:

* ``0``: done;
* ``1``: the work ran but a check failed (a validation row, a fit the data cannot support, a
  diagnosis without a conclusion, a plant state that is not finite), the disk was full, or an
  internal error (a bug: the line says so; ``HYDRO_TRACEBACK=1`` prints the traceback too);
* ``2``: bad input or usage (an argument, a file, a unit, a config, a parameter value, an output
  that would overwrite something), refused before the work where it can be.

An exception says its code with an ``exit_code`` attribute (the identification and diagnosis
errors whose data cannot give a result set 1); otherwise :func:`exit_code_for` maps its type.
:class:`Parser` is the ``argparse`` parser of the command line: its usage errors are one line too.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from collections.abc import Callable
from typing import Any, NoReturn

__all__ = ["EXIT_OK", "EXIT_FAIL", "EXIT_USAGE", "CliError", "CheckFailed", "Parser", "exit_code_for",
           "error_line", "report", "guarded"]

EXIT_OK = 0
EXIT_FAIL = 1
EXIT_USAGE = 2
#: longest message printed [characters]
MAX_LINE = 1000


class CliError(ValueError):
    """Bad input or usage found by a command (exit 2)."""

    exit_code = EXIT_USAGE


class CheckFailed(Exception):
    """The work ran and a check failed (exit 1)."""

    exit_code = EXIT_FAIL


def _is(exc: BaseException, module: str, name: str) -> bool:
    return any(c.__name__ == name and c.__module__.startswith(module) for c in type(exc).__mro__)


def exit_code_for(exc: BaseException) -> int:
    """The exit code of an exception that ends a command (module docstring)."""
    code = getattr(exc, "exit_code", None)
    if isinstance(code, int) and not isinstance(code, bool):
        return code
    if isinstance(exc, (FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError,
                        FileExistsError)):
        return EXIT_USAGE
    if isinstance(exc, OSError):  # a full disk, an I/O error: the run failed, the input was fine
        return EXIT_FAIL
    if isinstance(exc, (ValueError, TypeError, LookupError, ImportError)) or _is(exc, "gymnasium", "Error"):
        return EXIT_USAGE
    return EXIT_FAIL


def _message(exc: BaseException) -> str:
    if isinstance(exc, KeyError) and exc.args and type(exc).__str__ is KeyError.__str__:
        msg = str(exc.args[0])
    elif isinstance(exc, OSError) and exc.strerror:
        msg = exc.strerror if exc.filename is None else f"{exc.filename}: {exc.strerror}"
    else:
        msg = str(exc)
    msg = " ".join(msg.split())
    known = isinstance(exc, (ValueError, TypeError, LookupError, OSError, ImportError, CheckFailed)) \
        or _is(exc, "gymnasium", "Error") or hasattr(exc, "exit_code")
    if not msg:
        msg = type(exc).__name__
    elif not known:
        msg = (f"internal error: {type(exc).__name__}: {msg} (a bug, please report it; HYDRO_TRACEBACK=1 "
               "prints the traceback)")
    if len(msg) > MAX_LINE:
        msg = msg[: MAX_LINE - 3] + "..."
    return msg


def error_line(command: str, exc: BaseException | str) -> str:
    """``hydro <command>: error: <message>`` on one line."""
    msg = exc if isinstance(exc, str) else _message(exc)
    return f"{command}: error: {msg}"


def report(command: str, exc: BaseException | str) -> int:
    """Print :func:`error_line` to stderr; return the exit code of ``exc`` (2 for a message)."""
    print(error_line(command, exc), file=sys.stderr, flush=True)
    if isinstance(exc, BaseException) and os.environ.get("HYDRO_TRACEBACK"):
        traceback.print_exception(type(exc), exc, exc.__traceback__, file=sys.stderr)
    return EXIT_USAGE if isinstance(exc, str) else exit_code_for(exc)


def guarded(command: str, func: Callable[[Any], int | None], args: Any) -> int:
    """``func(args)`` with every exception reported as one line and turned into its exit code."""
    try:
        code = func(args)
    except KeyboardInterrupt:
        print(f"{command}: interrupted", file=sys.stderr)
        return 130
    except SystemExit:
        raise
    except BaseException as exc:  # noqa: BLE001 - the convention: one line, never a traceback
        return report(command, exc)
    return EXIT_OK if code is None else int(code)


class Parser(argparse.ArgumentParser):
    """``argparse`` with one-line usage errors (``<prog>: error: <message> (see --help)``, exit 2);
    its subparsers are of this class too."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} --help)\n")
