"""What ``pip install .`` (the README's install) brings runs every command the README shows:
every third-party module the package imports is a core dependency or belongs to an extra that
the code guards; every extra is used; every README command is a registered CLI command; and
``quadmodes sweep`` (dask.distributed, a core dependency) starts in a fresh process."""

import ast
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import typer

from quadmodes.cli.app import app

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "quadmodes"
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]

#: import name -> distribution that provides it (where they differ)
PROVIDED_BY = {"pydantic_core": "pydantic", "distributed": "dask", "vtkmodules": "pyvista"}
#: extra -> the modules it brings (each imported, or looked for with find_spec, by the package)
EXTRA_MODULES = {"viz": ("pyvista", "imageio"), "zarr": ("zarr",)}
#: optional modules outside any extra, each named in a one-line note where it is missing
UNLISTED_OPTIONAL = {"pypardiso"}


def _name(requirement: str) -> str:
    return re.split(r"[\[<>=!~; ]", requirement, maxsplit=1)[0].lower()


def _imports() -> set[str]:
    """Top-level third-party modules imported anywhere in the package (function level too)."""
    found = set()
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                found.update(a.name.split(".")[0] for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add(node.module.split(".")[0])
    return {m for m in found if m not in sys.stdlib_module_names and m != "quadmodes"}


def test_every_import_is_a_core_dependency_or_a_guarded_extra():
    core = {_name(r) for r in PROJECT["dependencies"]}
    optional = {m for mods in EXTRA_MODULES.values() for m in mods} | UNLISTED_OPTIONAL
    for module in _imports():
        dist = PROVIDED_BY.get(module, module)
        assert dist in core or dist in optional, f"{module} is imported but not a dependency"
    assert {"dask", "xarray", "h5netcdf", "pint"} <= core  # sweep and the files of every command
    assert "distributed" in next(r for r in PROJECT["dependencies"] if _name(r) == "dask")


def test_every_extra_is_used_and_complete():
    extras = PROJECT["optional-dependencies"]
    assert set(extras) - {"test"} == set(EXTRA_MODULES), "an extra nobody imports, or one unlisted"
    source = "\n".join(p.read_text(encoding="utf-8") for p in PACKAGE.rglob("*.py"))
    for extra, modules in EXTRA_MODULES.items():
        assert {_name(r) for r in extras[extra]} >= {m.replace("_", "-") for m in modules}, extra
        for module in modules:
            assert re.search(rf"import {module}\b|find_spec\(\"{module}\"\)|\"{module}\"", source), (
                f"[{extra}]: {module} is never used")


def _readme_commands() -> list[list[str]]:
    """The words after ``quadmodes`` of every command line in the README's bash blocks."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    out = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.splitlines():
            line = line.split("  #")[0]
            previous = None
            for part in re.split(r"&&|\|", line):
                words = part.split()
                if words[:1] == ["quadmodes"] or words[:3] == ["python", "-m", "quadmodes"]:
                    out.append(words[words.index("quadmodes") + 1:])
                    previous = out[-1][:1]
                elif previous and words[:1] == previous:  # quadmodes cache list | cache clear
                    out.append(words)
    return out


def test_every_readme_command_is_registered():
    group = typer.main.get_command(app)
    commands = _readme_commands()
    assert len(commands) > 15
    seen = set()
    for words in commands:
        names = [w for w in words if not w.startswith(("-", "[", "<", '"', "…")) and w.isascii()]
        if not names or words[0].startswith("-"):
            continue  # a global option: --version, --help, --quiet
        command = group.commands.get(names[0])
        assert command is not None, f"README: quadmodes {' '.join(words)}: no such command"
        seen.add(names[0])
        if isinstance(command, type(group)) and len(names) > 1:  # a command group: cache list
            assert names[1] in command.commands, f"README: quadmodes {' '.join(words)}"
    assert {"run", "sweep", "campbell", "compare", "cache", "modes"} <= seen


def test_sweep_starts_in_a_fresh_process():
    """``quadmodes sweep --help`` and the modules its run imports (dask.distributed)."""
    help_ = subprocess.run([sys.executable, "-m", "quadmodes", "sweep", "--help"],
                           capture_output=True, text=True, timeout=120)  # fmt: skip
    assert help_.returncode == 0, help_.stderr
    assert "--param" in help_.stdout and "Traceback" not in help_.stderr
    code = "import dask, distributed; from quadmodes.sweeps import engine, full_order, run"
    imported = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              timeout=120)  # fmt: skip
    assert imported.returncode == 0, imported.stderr


def test_the_plain_install_runs_the_compiled_step():
    """numba is a core dependency, so ``pip install .`` runs the compiled midpoint: the default
    back end of the default method is the kernel here (the numpy steppers only where numba
    cannot be imported)."""
    from quadmodes.rom import integrators, midpoint_kernel

    core = {_name(r) for r in PROJECT["dependencies"]}
    assert "numba" in core
    assert all("numba" not in {_name(r) for r in reqs}
               for name, reqs in PROJECT["optional-dependencies"].items() if name != "test")  # fmt: skip
    assert integrators._select_backend("auto", "midpoint") is midpoint_kernel
