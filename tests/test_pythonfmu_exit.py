"""A pythonfmu-exported plant leaves the bench's process with a clean heap. pythonfmu 0.7.0's library frees its
interpreter state twice at exit (C++'s static destructor, then its own library destructor writing into the freed
block): a clean CI run's `hil run --plant` of the foreign quadrotor ended "corrupted double-linked list", exit -6,
after a finished flight. Watched under valgrind: the FMU freed as the plant frees it (`FmuInstance.free`), and in a
second process as fmpy's `freeInstance` alone does (the control, so this test fails if valgrind stops seeing the
defect: the plant's release would then have nothing left to do). One copy a process: a second copy of the library
in the same process showed no write at exit even when freed by fmpy, so it could not tell the two apart."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

# The FMU unpacked, instantiated, initialised, stepped once, terminated and freed by the plant's path ("plant") or
# by fmpy's ("fmpy").
LOAD_STEP_FREE = """
import sys
from fmpy import extract, read_model_description
from plant_fmu.fmi import FmuInstance

fmu, path, free_by = sys.argv[1:]
description = read_model_description(fmu)
extract(fmu, unzipdir=path)
instance = FmuInstance(description.fmiVersion, path, description.coSimulation.modelIdentifier, description.guid,
                       "exit_check")
instance.setup_and_enter_initialization()
instance.exit_initialization()
step, tail = instance.stepper()
assert step(0.0, 0.002, *tail) == 0
instance.terminate()
instance.free() if free_by == "plant" else instance.slave.freeInstance()
"""


def libraries_written_after_free(valgrind_log: str) -> set[str]:
    """The FMU libraries named in valgrind's reports of a read or write into freed memory at exit."""
    libraries = set()
    for block in re.split(r"(?m)^==\d+== $", valgrind_log):
        if "Invalid" in block and "free'd" in block and "_dl_fini" in block:
            libraries.update(re.findall(r"\(in (\S+/binaries/\S+\.so)\)", block))
    return libraries


def under_valgrind(fmu: Path, unzip_dir: Path, free_by: str) -> subprocess.Popen[str]:
    return subprocess.Popen(["valgrind", f"--log-file={unzip_dir}.log", "--undef-value-errors=no", sys.executable,
                             "-c", LOAD_STEP_FREE, str(fmu), str(unzip_dir), free_by],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=dict(os.environ, PYTHONMALLOC="malloc"))


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind not installed (`make test-tools`)")
def test_the_plant_frees_a_pythonfmu_library_so_that_its_exit_writes_no_freed_memory(foreign_mapping, tmp_path):
    fmu = next(foreign_mapping.parent.glob("*.fmu"))
    runs = {free_by: under_valgrind(fmu, tmp_path / free_by, free_by) for free_by in ("plant", "fmpy")}
    for process in runs.values():
        output, _ = process.communicate(timeout=300)
        assert process.returncode == 0, output
    logs = {free_by: (tmp_path / f"{free_by}.log").read_text() for free_by in runs}
    assert libraries_written_after_free(logs["fmpy"]), "the control's write at exit is no longer seen"
    assert not libraries_written_after_free(logs["plant"]), logs["plant"]
