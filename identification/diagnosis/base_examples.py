"""Example ``--base`` files for ``hydro diagnose``: one per diagnosis plant, in ``configs/base/``.

Each is the plant's effect-free base model -- the seed rig's nominal parameters with every
catalogue effect at its null value (:func:`identification.diagnosis.models.null_base`) -- as
a plant preset (:func:`identification.ranges.load_preset`: ``{value, unit, source}`` per
field). Copy the one of your plant, replace the geometry (each plant's ``geometry`` fields),
masses and supply pressure by your rig's, keep the effects at their null values, and pass it
as ``--base``. The shipped files are regenerated with::

    python -m identification.diagnosis.base_examples --out configs/base
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from identification.diagnosis.models import null_base
from identification.diagnosis.plants import PLANTS, diagnosis_plant
from identification.ranges import preset_mapping, write_preset

__all__ = ["base_example", "write_base_examples"]


def base_example(plant: str) -> dict[str, Any]:
    """Preset mapping of ``plant``'s effect-free base model (see the module docstring)."""
    spec = diagnosis_plant(plant)
    nominal = spec.params_factory()
    p = null_base(spec, nominal)
    nulled = {f: f"null value of a catalogue effect (nominal {float(getattr(nominal, f)):.6g}): the base model "
                 "leaves the effect out, the diagnosis looks for it"
              for f in type(p).names() if float(getattr(p, f)) != float(getattr(nominal, f))}
    geo = ", ".join(type(p).geometry) or "none"
    return preset_mapping(p, f"{plant} base model",
                          f"example --base file: the seed rig's nominal values with every catalogue effect at its "
                          f"null value; replace the geometry ({geo}) and masses by your rig's", nulled)


def write_base_examples(out: str | Path) -> list[Path]:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    header = ("Example --base file for hydro diagnose (identification/diagnosis/base_examples.py).\n"
              "Edit the geometry and masses to your rig; keep the catalogue effects at their null values.")
    return [write_preset(out / f"{plant}.yaml", base_example(plant), header) for plant in PLANTS]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="configs/base")
    for p in write_base_examples(ap.parse_args(argv).out):
        print(p)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
