"""Start-up of the command line (issue 34): a command imports what it needs and nothing else,
the version is read without ``importlib.metadata``, and a warm blend loads every numba kernel
from the cache without numba's compiler registries (``benchmarks/cli_startup.py`` times it)."""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest

import elastic_motion
from elastic_motion.cli import COMMAND_MODULES, build_parser, subcommand_parsers

REPO = Path(__file__).resolve().parents[1]


def _run(code: str) -> str:
    """Standard output of ``code`` in a fresh interpreter."""
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout


# ------------------------------------------------------------------------------------------
# The version
# ------------------------------------------------------------------------------------------


def test_importing_the_package_reads_no_distribution_metadata():
    """``importlib.metadata.version`` scans the installed distributions: not at start-up."""
    out = _run("import sys, elastic_motion\nprint('importlib.metadata' in sys.modules)")
    assert out.strip() == "False"


def test_the_version_has_one_home():
    project = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert "version" in project["project"]["dynamic"] and "version" not in project["project"]
    attr = project["tool"]["setuptools"]["dynamic"]["version"]["attr"]
    assert attr == "elastic_motion._version.__version__"
    try:
        installed = metadata.version("elastic-motion")
    except metadata.PackageNotFoundError:  # a source tree that is not installed
        return
    assert installed == elastic_motion.__version__


# ------------------------------------------------------------------------------------------
# One command, one command module
# ------------------------------------------------------------------------------------------


def test_command_modules_name_what_each_module_registers():
    everything = list(subcommand_parsers(build_parser()))
    assert everything == [c for commands in COMMAND_MODULES.values() for c in commands]
    for commands in COMMAND_MODULES.values():
        for command in commands:
            assert list(subcommand_parsers(build_parser(command))) == list(commands)
    assert list(subcommand_parsers(build_parser("no-such-command"))) == everything


def test_a_command_line_imports_its_command_module_alone():
    code = (
        "import sys\nfrom elastic_motion.cli import main\n"
        "try:\n    main(['info', '--help'])\nexcept SystemExit:\n    pass\n"
        "print(' '.join(m for m in sys.modules if m.startswith('elastic_motion.cli_commands.')))"
    )
    loaded = {m.rsplit(".", 1)[1] for m in _run(code).splitlines()[-1].split()}  # (after the help)
    assert "info" in loaded
    assert not (loaded & set(COMMAND_MODULES)) - {"info"}


def test_the_report_path_check_loads_no_app():
    """``check_report_target`` runs before every command: without ``--json`` it imports
    nothing, with it no database app (its asyncio, Dask engines, numba kernels)."""
    code = (
        "import sys\nfrom elastic_motion.cli import build_parser\n"
        "from elastic_motion.cli_commands._paths import check_report_target\n"
        "p = build_parser('blend')\n"
        "check_report_target(p.parse_args(['blend', 'a.bvh', 'b.bvh', '-o', 'o.bvh']))\n"
        "print('numpy' in sys.modules)\n"
        "check_report_target(p.parse_args(['blend', 'a.bvh', 'b.bvh', '-o', 'o.bvh', '--json', 'r.json']))\n"
        "print('elastic_motion.apps.database' in sys.modules)"
    )
    assert _run(code).split() == ["False", "False"]


# ------------------------------------------------------------------------------------------
# A warm blend of two real walks, in a fresh process
# ------------------------------------------------------------------------------------------

#: Modules a blend of two BVH files has no use for: the database app, the cycles app (cycles
#: and loops), the statistics app (the Karcher template of three motions), the loop app and its
#: closing solvers (scipy.sparse, scipy.linalg), scipy.ndimage (elastic_motion.motion.filters),
#: scipy's signal, interpolation (cubic resampling only), spatial, optimisation and special
#: functions, plotting, XML (URDF); numba's array-math implementations, which a cached
#: kernel's load imports when the kernel calls one of them (np.round, np.searchsorted, ...: its
#: environment names the module), and with them scipy.linalg (numba.np.linalg.ensure_blas),
#: together 0.2 s.
NOT_IN_A_BLEND = (
    "elastic_motion.apps.database",
    "elastic_motion.apps.loop",
    "elastic_motion.apps.cycles",
    "elastic_motion.apps.statistics",
    "elastic_motion.closing",
    "scipy.sparse",
    "scipy.linalg",
    "scipy.ndimage",
    "scipy.signal",
    "scipy.interpolate",
    "scipy.spatial",
    "scipy.optimize",
    "scipy.special",
    "matplotlib",
    "numba.np.arraymath",
    "asyncio",
    "xml.etree",
)

_BLEND = """
import json, sys
import numba
from numba.core.typing.context import BaseContext
refreshes = []
_refresh = BaseContext.refresh
def counted(self):
    refreshes.append(1)
    return _refresh(self)
BaseContext.refresh = counted
from elastic_motion.cli import main
code = main(sys.argv[1:])
misses, hits, signatures = {}, 0, {}
for name, mod in list(sys.modules.items()):
    if not name.startswith("elastic_motion"):
        continue
    for obj in vars(mod).values():
        if isinstance(obj, numba.core.registry.CPUDispatcher) and obj.__module__ == name:
            hits += sum(obj.stats.cache_hits.values())
            if sum(obj.stats.cache_misses.values()):
                misses[f"{name}.{obj.__name__}"] = dict(obj.stats.cache_misses)
            if obj.signatures:
                signatures[f"{name}.{obj.__name__}"] = [str(s) for s in obj.signatures]
from numba.core import entrypoints
print(json.dumps({"code": code, "refreshes": len(refreshes), "misses": {k: str(v) for k, v in misses.items()},
                  "hits": hits, "signatures": signatures, "modules": sorted(sys.modules),
                  "extensions": entrypoints._already_initialized}))
"""


@pytest.fixture(scope="module")
def warm_blend(mocap_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """What the second of two identical blends (the first fills numba's cache) loaded."""
    bvh = mocap_dir / "cmu" / "bvh"
    out = tmp_path_factory.mktemp("blend") / "out.bvh"
    args = ["blend", str(bvh / "07_01.bvh"), str(bvh / "08_02.bvh"), "-o", str(out), "-q", "--trim", "0:1.2"]
    for _ in range(2):
        out_text = subprocess.run(
            [sys.executable, "-c", _BLEND, *args], capture_output=True, text=True, check=True
        ).stdout
    report = json.loads(out_text.strip().splitlines()[-1])
    assert report["code"] == 0
    return report


def test_a_blend_imports_no_other_app(warm_blend: dict):
    loaded = set(warm_blend["modules"])
    assert not {m for m in NOT_IN_A_BLEND if m in loaded}


def test_a_warm_blend_loads_every_kernel_from_the_cache(warm_blend: dict):
    assert warm_blend["hits"] >= 10 and warm_blend["misses"] == {}


def test_a_warm_blend_loads_each_kernel_once(warm_blend: dict):
    """One type signature per kernel (each load of a cached kernel costs start-up time): a
    read-only and a writable array are two numba types (elastic_motion.groups passes its
    kernels read-only arrays)."""
    assert {k: v for k, v in warm_blend["signatures"].items() if len(v) > 1} == {}


def test_a_warm_blend_never_loads_numbas_compiler_registries(warm_blend: dict):
    """Running cached kernels needs numba's runtime only (elastic_motion._numba_cache): the
    registries (half the bare Python's start-up) are never loaded by a warm blend."""
    assert warm_blend["refreshes"] == 0


def test_a_warm_blend_never_scans_for_numba_extensions(warm_blend: dict):
    """numba's extension set-up reads every installed distribution's metadata (7-13 ms); the
    package's kernels need no extension (elastic_motion._numba_cache)."""
    assert warm_blend["extensions"] is False


def test_a_users_function_still_sets_up_numbas_extensions():
    """Skipped for the package's kernels only: the set-up hook of a user's own @njit function
    runs numba's extension set-up (before its arguments are typed) as numba does."""
    code = (
        "import numba\n"
        "from numba.core import entrypoints\n"
        "from elastic_motion.groups import _so3_exp_kernel\n"
        "_so3_exp_kernel._compilation_chain_init_hook()\n"
        "print(entrypoints._already_initialized)\n"
        "@numba.njit\n"
        "def f(x):\n    return x + 1.0\n"
        "f._compilation_chain_init_hook()\n"
        "print(entrypoints._already_initialized)"
    )
    assert _run(code).split() == ["False", "True"]


def test_importing_the_kernels_sets_no_cache_up():
    """numba proves each cache folder writable with a temporary file when ``@njit(cache=True)``
    runs; the package's kernels set their caches up on first use (the warm blend above loads
    every kernel it calls from its cache)."""
    code = (
        "import tempfile\n"
        "made = []\n"
        "real = tempfile.TemporaryFile\n"
        "tempfile.TemporaryFile = lambda *a, **k: made.append(1) or real(*a, **k)\n"
        "import numpy as np\n"
        "import elastic_motion.warp, elastic_motion.motion\n"
        "print(len(made))\n"
        "from elastic_motion.groups import SO3, _so3_exp_kernel\n"
        "SO3().exp(np.array([[0.1, 0.2, 0.3]]))\n"
        "print(len(made), bool(_so3_exp_kernel.stats.cache_path))"
    )
    assert _run(code).split() == ["0", "1", "True"]


def test_a_compile_after_a_light_load_still_finds_the_registries():
    """numba refreshes its contexts itself when it compiles: a new kernel after a cached one
    (np.sum, np.full: implementations from the registries) compiles and runs."""
    code = (
        "import numpy as np, numba\n"
        "from elastic_motion.groups import SO3\n"
        "r = SO3().exp(np.array([[0.1, 0.2, 0.3]]))\n"
        "@numba.njit\n"
        "def f(a):\n    return np.sum(np.full(a.shape, 2.0) * a)\n"
        "print(f(np.ones(4)), float(np.trace(r[0])) > 2.0)"
    )
    assert _run(code).split() == ["8.0", "True"]
