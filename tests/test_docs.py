"""The docs are a reference a user can read away from the development machine."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SEEDS = ("000", "001", "002", "003", "004")

# a path of the development machine, or of the material beside the repository there
_DEV_PATH = re.compile(r"/work/|\.\./shared/|shared/(seeds|NOTES|tools|data)")


def _doc_files():
    for folder in ("hydro_envs", "identification", "agents", "docs", "bench"):
        for path in sorted((ROOT / folder).rglob("*")):
            if path.suffix in (".py", ".md", ".yaml", ".yml") and "pretrained" not in path.parts:
                yield path
    yield ROOT / "README.md"
    yield ROOT / "CONTRIBUTING.md"


def test_no_development_machine_paths_in_docs_docstrings_or_configs():
    hits = []
    for path in _doc_files():
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if _DEV_PATH.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert not hits, "\n".join(hits)


def test_references_name_every_seed_the_code_cites():
    refs = (ROOT / "docs" / "references.md").read_text(encoding="utf-8")
    rows = {m.group(1): m.group(2) for m in re.finditer(r"^\| (\d{3}) \| `(\d{3}_[0-9a-f]{16}\.txt)` \|", refs, re.M)}
    assert sorted(rows) == list(SEEDS), rows
    assert all(name.startswith(num + "_") for num, name in rows.items())
    cited = set()
    for path in _doc_files():
        text = path.read_text(encoding="utf-8")
        cited |= set(re.findall(r"\b(\d{3}_[0-9a-f]{16}\.txt)", text))
        cited |= {f"seed-{n}" for n in re.findall(r"\bseeds? (0\d\d)\b", text)}
    unknown = {c for c in cited if c not in rows.values() and c.removeprefix("seed-") not in rows}
    assert not unknown, unknown
    # a DOI is only given where a record of the paper shows it, never invented
    for line in refs.splitlines():
        if line.startswith("| 00"):
            assert "DOI not printed in the seed" in line or "public record: 10." in line, line


def test_readme_is_a_reference_of_about_400_lines_with_a_references_section():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= 420
    for heading in ("## Install", "## Quick start", "## Command line", "## References"):
        assert heading in readme, heading
    refs = readme[readme.index("## References"):]
    for num in SEEDS:
        assert f"- {num}: *" in refs, num
    assert "Linux x86-64" in readme  # the supported platform is stated
    assert not re.search(r"\bcommit [0-9a-f]{7}\b", readme)  # measured history lives in docs/history
