"""The ``cache`` commands: ``quadmodes cache list`` and ``quadmodes cache clear``."""

from __future__ import annotations

import json
import sys

import typer
from rich.markup import escape
from rich.table import Table

from quadmodes.cli.common import JsonFlag, UserError, err, flag, one_line_errors, out
from quadmodes.cli.shape import QuadmodesCommand, QuadmodesGroup

cache_app = typer.Typer(
    cls=QuadmodesGroup,
    no_args_is_help=True,
    add_completion=False,
    help="List or clear the cached reduced models, spectra and damping modes "
    "($QUADMODES_CACHE, else the per-user cache folder).",
)


@cache_app.command("list", cls=QuadmodesCommand)
def cache_list(as_json: JsonFlag = False) -> None:
    """List the cache entries: case, kind, modes, reference spin, size and age."""
    from quadmodes.models.cache import cache_dir
    from quadmodes.models.cache_entries import cache_entries, format_age, format_size

    folder = cache_dir()
    entries = cache_entries(folder)
    if as_json:
        rows = [{"case": e.case, "kind": e.kind, "modes": e.modes, "spin": e.spin, "key": e.key,
                 "size_bytes": e.size_bytes, "age_s": round(e.age_s, 1), "path": str(e.path)}
                for e in entries]  # fmt: skip
        sys.stdout.write(json.dumps({"cache_dir": str(folder), "entries": rows}, indent=2) + "\n")
        return
    # names wrap rather than being cut, and the key shows its first 8 hex digits (all 16 in
    # --json): the table keeps every value readable in 80 columns
    table = Table(title=f"cache: {escape(str(folder))}")
    table.add_column("case", overflow="fold")
    for name in ("kind", "modes", "about", "size", "age", "key"):
        table.add_column(name, no_wrap=True)
    for e in entries:
        table.add_row(e.case, e.kind, e.modes, e.spin or ("rest" if e.kind != "damping" else ""),
                      format_size(e.size_bytes), format_age(e.age_s), e.key[:8])  # fmt: skip
    out.print(table)
    total = sum(e.size_bytes for e in entries)
    out.print(f"{len(entries)} entries, {format_size(total)}")


@cache_app.command("clear", cls=QuadmodesCommand)
def cache_clear(yes: flag("--yes", "remove without asking") = False) -> None:
    """Remove every cache entry and its lock file (only files the cache wrote; other files in
    the folder are kept)."""
    from quadmodes.models.cache import cache_dir
    from quadmodes.models.cache_entries import cache_entries, clear_entries, format_size

    folder = cache_dir()
    entries = cache_entries(folder, locks=True)
    if not entries:
        out.print(f"cache {escape(str(folder))} is empty")
        return
    total = format_size(sum(e.size_bytes for e in entries))
    with one_line_errors():
        if not yes:
            if not sys.stdin.isatty():
                raise UserError(
                    f"cache clear: would remove {len(entries)} files ({total}) from {folder}; "
                    "pass --yes to remove them"
                )
            if not typer.confirm(f"remove {len(entries)} files ({total}) from {folder}?"):
                err.print("nothing removed")
                raise typer.Exit(code=1)
    removed, freed = clear_entries(entries)
    out.print(f"removed {removed} files ({format_size(freed)}) from {escape(str(folder))}")
