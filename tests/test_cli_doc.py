"""docs/cli.md is the command-line reference: every subcommand and every option is on it."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from hydro_envs.cli import build_parser

DOC = Path(__file__).resolve().parents[1] / "docs" / "cli.md"


def _commands(parser: argparse.ArgumentParser, prefix: str = "hydro"):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                inner = list(_commands(sub, f"{prefix} {name}"))
                yield from inner or [(f"{prefix} {name}", sub)]


def test_every_command_has_a_section_and_every_option_is_named():
    text = DOC.read_text(encoding="utf-8")
    commands = list(_commands(build_parser()))
    assert len(commands) >= 12, [c for c, _ in commands]  # 7 commands + 5 identify methods
    missing = []
    for name, parser in commands:
        if f"### `{name}`" not in text:
            missing.append(name)
        for action in parser._actions:
            if action.help == argparse.SUPPRESS:
                continue
            for flag in action.option_strings:
                if flag.startswith("--") and flag != "--help" and not re.search(f"`{flag}[` ]", text):
                    missing.append(f"{name} {flag}")
    assert not missing, missing
