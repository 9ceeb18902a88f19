"""The README's commands are the ones CI runs."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    return re.findall(r"```sh\n(.*?)\n```", text, flags=re.DOTALL)


def test_ci_runs_the_readme_test_command():
    test_commands = [c for c in readme_commands() if "pytest" in c]
    assert len(test_commands) == 1
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert test_commands[0] in ci


def test_import_does_not_import_pygame():
    import subprocess
    import sys

    code = "import sys, sdfphys; sys.exit('pygame' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


def test_readme_run_command_names_a_scene_that_exists():
    runs = [c for c in readme_commands() if "sdfphys run" in c]
    assert len(runs) == 1
    scene = runs[0].split("sdfphys run ")[1].split()[0]
    assert (ROOT / scene).is_file()


def test_readme_lists_every_primitive():
    import sdfphys

    text = (ROOT / "README.md").read_text()
    assert f"Primitives ({len(sdfphys.sdf.PRIMITIVES)})" in text
    for name in sdfphys.sdf.PRIMITIVES:
        assert f" {name}," in text or f" {name}." in text or f"\n{name}," in text, name
