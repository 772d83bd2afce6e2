"""Test-suite configuration.

Hypothesis runs derandomized by default (the ``ci`` profile): the same examples on every run,
so `make test` is reproducible and a red CI can be replayed. ``HYPOTHESIS_PROFILE=explore``
draws fresh random examples (that is how the lone-CR loader bug was found); add what it finds
as an ``@example``.
"""

from __future__ import annotations

import os

try:
    from hypothesis import settings
except ImportError:  # pragma: no cover - hypothesis is in the test extra
    pass
else:
    settings.register_profile("ci", derandomize=True, print_blob=True)
    settings.register_profile("explore", derandomize=False, print_blob=True)
    settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
