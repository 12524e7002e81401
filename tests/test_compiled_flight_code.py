"""The emulator's compiled flight code (firmware_interface/emulator/compiled.py, a group of
firmware_interface/compiled_code.py): compiled once, loaded after, and compiled afresh when any of its sources
changes."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from firmware_interface.compiled_code import CompiledCode
from firmware_interface.emulator import compiled
from firmware_interface.link import frame_packing

ROOT = Path(__file__).resolve().parent.parent

# Flies every registered controller for 2 s on the estimator and the plant FMU (tests/support/closed_loop.py), samples a
# navigator move, then prints numba's cache counters summed over every compiled function of the flight code.
FLY_AND_COUNT = """
import json
import numpy as np
from firmware_interface.emulator import compiled
from firmware_interface.emulator.trajectory import quintic_sample
from firmware_interface.emulator.config import build_config
from firmware_interface.emulator.control.registry import CONTROLLERS
from hil.sensors import SensorsConfig
from tests.support.closed_loop import PAPER_PLANT, hover, fly

for name in CONTROLLERS:
    fly(build_config({"controller": name, "airframe": "paper_airframe"}), PAPER_PLANT, hover((0.0, 0.0, -5.0)),
        2.0, start=(0.0, 0.0, -5.0), sensors=SensorsConfig())
quintic_sample(np.zeros((3, 6)), 0.5)
laws = {f"{c.py_func.__module__}.{c.py_func.__qualname__}": c.dispatcher.stats for c in compiled.FLIGHT_CODE.entries
        if c.dispatcher is not None}
print(json.dumps({"cache_dir": str(compiled.FLIGHT_CODE.cache_dir),
                  "hits": {name: sum(stats.cache_hits.values()) for name, stats in laws.items()},
                  "misses": {name: sum(stats.cache_misses.values()) for name, stats in laws.items()}}))
"""


def fly_and_count(cache_home: Path) -> dict:
    env = os.environ | {"XDG_CACHE_HOME": str(cache_home)}
    result = subprocess.run([sys.executable, "-c", FLY_AND_COUNT], cwd=ROOT, env=env, capture_output=True,
                            text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    return json.loads(result.stdout.splitlines()[-1])


@pytest.mark.slow
def test_the_first_process_compiles_the_flight_code_and_the_next_one_loads_it(tmp_path):
    first = fly_and_count(tmp_path)
    flown = {name.rsplit(".", 2)[-2] + "." + name.rsplit(".", 1)[-1] for name in first["misses"]}
    assert {"estimator.sensor_sample", "estimator.estimate_of", "mixer.rotor_commands", "smarc.smarc_step",
            "smpid.smpid_step", "backstepping.backstepping_step"} <= flown
    assert Path(first["cache_dir"]).is_relative_to(tmp_path) and any(Path(first["cache_dir"]).iterdir())
    assert all(first["misses"].values()) and not any(first["hits"].values())  # each compiled here
    second = fly_and_count(tmp_path)
    assert not any(second["misses"].values()) and all(second["hits"].values())  # each loaded, none compiled


def test_the_bench_and_its_commands_start_without_loading_the_compiler():
    """numba costs ~0.2 s to import: only a process that flies the emulator's flight code pays it."""
    probe = "import sys, hil.app.cli, hil.run.runner; print('numba' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert result.stdout.strip() == "False", result.stderr[-2000:]


def test_the_cache_is_named_after_every_flight_code_source(tmp_path, monkeypatch):
    """numba would only notice a change in the calling function's own file; a change of a helper anywhere in
    the emulator's sources (or in a module of another package the group names) must give compiled code of its
    own."""
    package = tmp_path / "emulator"
    emulator_sources = compiled.FLIGHT_CODE.sources[0]
    shutil.copytree(emulator_sources, package, ignore=shutil.ignore_patterns("__pycache__"))
    packing = tmp_path / "frame_packing.py"
    packing.write_text(Path(frame_packing.__file__).read_text())
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))

    def cache_dir():  # the directory a process starting now would use
        return CompiledCode("flight-code", (package, packing)).cache_dir

    before = cache_dir()
    assert before.parent == tmp_path / "cache" / "hil-bench"
    assert cache_dir() == before  # the same sources, the same compiled code
    helper = package / "geometry.py"
    helper.write_text(helper.read_text().replace("return (angle + math.pi)", "return (angle + 1.0 * math.pi)"))
    after_helper = cache_dir()
    assert after_helper != before
    packing.write_text(packing.read_text().replace("crc = 0xFFFF", "crc = 0xFFFF  # seed"))
    assert cache_dir() != after_helper


def test_the_flight_code_group_names_the_emulator_and_every_module_it_compiles_in():
    sources = {path.name for path in compiled.FLIGHT_CODE.sources}
    assert Path(compiled.FLIGHT_CODE.sources[0]) == Path(compiled.__file__).parent
    assert {"frame_packing.py", "compiled_code.py"} <= sources


def test_groups_made_on_two_threads_keep_their_own_cache_directories(tmp_path, monkeypatch):
    """numba reads its cache directory setting twice while a dispatcher picks its cache; a group made on another
    thread (the bench loads its step's code beside the board's start) must not put the setting back in between.
    The interleaving that left a dispatcher's cache in the working directory, forced: the first group's set-up
    pauses inside numba until the second's has begun (or 0.5 s, when a lock keeps it out), then ends first."""
    import numba

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    first_inside, second_inside = threading.Event(), threading.Event()
    seen: dict[str, str] = {}

    def njit_seeing_the_setting(cache: bool):  # what numba reads while a dispatcher picks its cache
        def make(function):
            if function.__name__ == "first":
                first_inside.set()
                second_inside.wait(0.5)
            else:
                second_inside.set()
                time.sleep(0.1)  # the first group's set-up ends meanwhile, without a lock
            seen[function.__name__] = numba.config.CACHE_DIR
            return function
        return make

    monkeypatch.setattr(numba, "njit", njit_seeing_the_setting)

    def first():
        return 1

    def second():
        return 2

    entries = {f.__name__: CompiledCode(f.__name__, (tmp_path,)).compiled(f) for f in (first, second)}
    made = threading.Thread(target=entries["first"])
    made.start()
    assert first_inside.wait(5.0)
    entries["second"]()
    made.join(5.0)
    for name, entry in entries.items():
        assert seen[name] == str(entry.group.cache_dir)
