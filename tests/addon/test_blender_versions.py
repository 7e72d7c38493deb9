"""The extension zip in every Blender the manifest admits besides 4.5 (which runs all the other add-on
tests): the oldest (4.2 LTS), the last on Python 3.11 (5.0) and the newest (5.2 LTS, Python 3.13), each
as its own Python module installed by .ci/setup. blender_smoke.py installs the zip as a user would and
walks through resolve, inspect, both render engines, Bake Frames and the jellyfish; the process must
exit 0."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SMOKE = Path(__file__).with_name("blender_smoke.py")
STEPS = ["install and register", "resolve", "inspect", "render cycles", "render layered", "bake frames", "clear",
         "jellyfish add and bake", "unregister"]


@pytest.mark.parametrize("version", ["4.2", "5.0", "5.2"])
def test_the_extension_installs_works_and_exits_cleanly_in_blender(extension_zip, version):
    python = ROOT / ".venv-blender" / version / "bin" / "python"
    if not python.is_file():
        if os.environ.get("CI"):
            pytest.fail(f"no Blender {version} module: bash .ci/setup installs it")
        pytest.skip(f"no Blender {version} module here: bash .ci/setup installs it when its Python is installed")
    run = subprocess.run([str(python), str(SMOKE), str(extension_zip)], capture_output=True, text=True, timeout=900)
    lines = run.stdout.splitlines()
    said = "\n".join(lines[-15:] + run.stderr.splitlines()[-15:])
    assert lines and lines[0].startswith(f"blender {version}."), said
    assert [ln[: -len(": ok")] for ln in lines if ln.endswith(": ok")] == STEPS, said
    assert "done" in lines, said
    assert run.returncode == 0, f"exit code {run.returncode} (139: a crash on the way out)\n{said}"
