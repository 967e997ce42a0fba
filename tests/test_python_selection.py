"""The Python that `make setup` builds .venv with (tools/pick_python.sh and the Makefile).

Each test puts small shell scripts named python3, python3.12, ... in a folder and makes it
the whole PATH: each reports a version when asked with ``-c`` (as the picker asks), writes
every call to a log, and fails anything else, so that no real interpreter or pip can run.
"""

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PICKER = ROOT / "tools" / "pick_python.sh"
DEADLINE_S = 30
SUPPORTED_LINE_START = "imimic_gym needs Python 3.10, 3.11 or 3.12"


class FakePythons:
    """A folder of fake interpreters, the only folder on PATH, with a log of their calls."""

    def __init__(self, folder: Path) -> None:
        self.bin = folder / "bin"
        self.bin.mkdir()
        self.log = folder / "calls.log"
        self.log.touch()

    def add(self, name: str, version: str | None) -> Path:
        """A fake ``name`` that reports ``version`` ("3.13"), or fails every call (None)."""
        answer = f'[ "$1" = "-c" ] && echo {version} && exit 0\n' if version else ""
        script = self.bin / name
        script.write_text(f'#!/bin/sh\necho "{name} $*" >> "{self.log}"\n{answer}exit 1\n')
        script.chmod(0o755)
        return script

    def env(self) -> dict[str, str]:
        return {"PATH": str(self.bin), "HOME": str(self.bin.parent)}

    def calls(self) -> list[str]:
        return self.log.read_text().splitlines()


@pytest.fixture
def fakes(tmp_path: Path) -> FakePythons:
    return FakePythons(tmp_path)


def pick(fakes: FakePythons, *python: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["/bin/sh", str(PICKER), *python], env=fakes.env(),
                          capture_output=True, text=True, timeout=DEADLINE_S)


def make(fakes: FakePythons, *arguments: str) -> subprocess.CompletedProcess[str]:
    make_path = shutil.which("make")
    assert make_path is not None, "make is not installed"
    return subprocess.run([make_path, "--no-print-directory", "-C", str(ROOT), *arguments],
                          env=fakes.env(), capture_output=True, text=True, timeout=DEADLINE_S)


def test_a_supported_python3_is_used_as_it_is(fakes: FakePythons) -> None:
    python3 = fakes.add("python3", "3.11")
    fakes.add("python3.12", "3.12")

    result = pick(fakes)

    assert (result.returncode, result.stdout, result.stderr) == (0, f"{python3}\n", "")


def test_python_3_13_gives_way_to_python3_12_beside_it(fakes: FakePythons) -> None:
    fakes.add("python3", "3.13")
    python312 = fakes.add("python3.12", "3.12")
    fakes.add("python3.11", "3.11")

    result = pick(fakes)

    assert (result.returncode, result.stdout) == (0, f"{python312}\n")
    assert result.stderr == ("pick_python: python3 is Python 3.13, not 3.10-3.12; "
                             "using python3.12 (Python 3.12)\n")


def test_the_newest_supported_python_is_taken_first(fakes: FakePythons) -> None:
    fakes.add("python3", "3.13")
    python311 = fakes.add("python3.11", "3.11")
    fakes.add("python3.10", "3.10")

    assert pick(fakes).stdout == f"{python311}\n"


def test_a_python_that_fails_to_run_is_passed_over(fakes: FakePythons) -> None:
    fakes.add("python3", None)
    python310 = fakes.add("python3.10", "3.10")

    result = pick(fakes)

    assert result.stdout == f"{python310}\n"
    assert "python3 is not found" in result.stderr


def test_the_python_named_by_the_user_is_used_from_anywhere(fakes: FakePythons,
                                                           tmp_path: Path) -> None:
    fakes.add("python3", "3.11")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    own = elsewhere / "python3.12"
    shutil.copy(fakes.add("python3.12", "3.12"), own)

    assert pick(fakes, str(own)).stdout == f"{own}\n"


def test_an_unsupported_python_named_by_the_user_gives_way_too(fakes: FakePythons) -> None:
    fakes.add("python3.13", "3.13")
    python311 = fakes.add("python3.11", "3.11")

    result = pick(fakes, "python3.13")

    assert result.stdout == f"{python311}\n"
    assert result.stderr.startswith("pick_python: python3.13 is Python 3.13,")


def test_with_no_supported_python_one_line_says_what_to_install(fakes: FakePythons) -> None:
    fakes.add("python3", "3.13")
    fakes.add("python3.10", "3.9")

    result = pick(fakes)

    assert (result.returncode, result.stdout) == (1, "")
    assert result.stderr.count("\n") == 1
    line = result.stderr.rstrip("\n")
    assert line.startswith(SUPPORTED_LINE_START)
    assert "found: python3 is 3.13, python3.10 is 3.9)" in line
    assert "uv python install 3.12" in line
    assert "make PYTHON=/path/to/python3.12" in line


def test_with_no_python_at_all_the_line_says_none_was_found(fakes: FakePythons) -> None:
    result = pick(fakes)

    assert result.returncode == 1
    assert "found: none)" in result.stderr


def test_make_setup_builds_the_venv_with_the_picked_python(fakes: FakePythons,
                                                          tmp_path: Path) -> None:
    fakes.add("python3", "3.13")
    fakes.add("python3.12", "3.12")
    venv = tmp_path / "venv"

    result = make(fakes, "setup", f"VENV={venv}")

    # The fake fails `-m venv`, so make stops there: nothing else ran.
    assert result.returncode != 0
    asked = "import sys; print(\"%d.%d\" % sys.version_info[:2])"
    assert fakes.calls() == [f"python3 -c {asked}", f"python3.12 -c {asked}",
                             f"python3.12 -m venv {venv}"]


def test_make_setup_without_a_supported_python_stops_before_pip(fakes: FakePythons,
                                                                tmp_path: Path) -> None:
    fakes.add("python3", "3.13")
    venv = tmp_path / "venv"

    result = make(fakes, "setup", f"VENV={venv}")

    assert result.returncode != 0
    ours = [line for line in result.stderr.splitlines() if line.startswith("imimic_gym")]
    assert len(ours) == 1 and ours[0].startswith(SUPPORTED_LINE_START)
    assert "pip install" not in result.stdout
    assert "Traceback" not in result.stdout + result.stderr
    assert all(" -m " not in call for call in fakes.calls())
    assert not venv.exists()


def test_make_python_reports_the_choice_and_installs_nothing(fakes: FakePythons) -> None:
    fakes.add("python3", "3.13")
    python312 = fakes.add("python3.12", "3.12")

    result = make(fakes, "python")

    assert (result.returncode, result.stdout) == (0, f"{python312}\n")
    assert all(" -m " not in call for call in fakes.calls())


def test_make_python_is_overridden_by_the_command_line(fakes: FakePythons) -> None:
    fakes.add("python3", "3.12")
    python310 = fakes.add("python3.10", "3.10")

    assert make(fakes, "python", "PYTHON=python3.10").stdout == f"{python310}\n"


def test_pyproject_and_readme_name_the_pythons_the_picker_takes() -> None:
    pyproject = (ROOT / "pyproject.toml").read_text()
    classified = re.findall(r'"Programming Language :: Python :: (3\.\d+)"', pyproject)
    assert classified == ["3.10", "3.11", "3.12"]
    pose_extra = re.search(r"^pose = \[(.*?)\]$", pyproject, re.M | re.S)
    assert pose_extra is not None
    requirements = re.findall(r'"([^"]+)"', pose_extra.group(1))
    assert requirements and all(r.endswith("; python_version < '3.13'") for r in requirements)
    assert "Both need only Python 3.10, 3.11 or 3.12" in (ROOT / "README.md").read_text()
