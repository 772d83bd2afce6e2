"""The command ``make demo-diagnose`` prints ("equivalent command") gives the demo's verdicts
and named effects when run on its own through the ``hydro`` CLI on the files the demo wrote."""

from __future__ import annotations

import json
import re
import shlex

import pytest


@pytest.mark.slow  # ~60 s: the demo's two cases, then the same two through the CLI
def test_the_printed_command_gives_the_demo_verdicts(tmp_path, capsys):
    from hydro_envs.cli import main as hydro
    from identification.diagnosis.demo import main as demo

    assert demo(["--out", str(tmp_path), "--seconds", "6"]) == 0
    out = capsys.readouterr().out
    commands = re.findall(r"^equivalent command: (.+)$", out, flags=re.M)
    verdicts = re.findall(r"^verdict: (\S+)", out, flags=re.M)
    named = re.findall(r"^(?:FOUND the hidden effect|did NOT find .*)$", out, flags=re.M)
    assert len(commands) == len(verdicts) == len(named) == 2, out[-2000:]
    for i, cmd in enumerate(commands):
        argv = shlex.split(cmd)
        assert argv[:2] == ["hydro", "diagnose"] and "--base" in argv, cmd
        argv = [a if a != argv[argv.index("--out") + 1] else str(tmp_path / f"cli{i}") for a in argv[1:]]
        assert hydro(argv + ["--json"]) == 0
        res = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert res["verdict"] == verdicts[i], (cmd, res["verdict"], res["reason"])
        plant = argv[argv.index("--plant") + 1]
        hidden = {"servo_cylinder": "stribeck", "shaking_table": "modified_ifas"}[plant]
        assert [e["name"] for e in res["effects"]][:1] == [hidden], (cmd, res["effects"])
