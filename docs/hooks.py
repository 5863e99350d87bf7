"""Build-time pieces of the documentation site (MkDocs hooks, ``hooks:`` in mkdocs.yml).

The pages that must not drift from the code are generated here when the site is built:

* ``cli.md``: the ``--help`` text of every command of ``sarjax.cli.commands.cli``;
* ``config.md``: the TOML configuration, from ``sarjax.cli.config.EXAMPLE``;
* ``simulators.md``: each simulator's declarations and the budget thresholds, from the
  simulator classes and ``sarjax.simulators._budgets``.

A page asks for a piece with a marker line ``<!-- sarjax:NAME -->``. The module also
holds :class:`SphinxRoles`, a griffe extension (``extensions:`` of the mkdocstrings
handler) that turns the Sphinx roles of the docstrings into optional cross-references.
"""

from __future__ import annotations

import re
import tomllib

import click
import griffe

MARKER = re.compile(r"^<!-- sarjax:([a-z_]+) -->$", flags=re.MULTILINE)
HELP_WIDTH = 100


# --------------------------------------------------------------------------- CLI


def command_help(command: click.Command, path: tuple[str, ...]) -> str:
    """The ``--help`` text of ``command`` as ``sarjax VERB --help`` prints it."""
    parent = None
    for name in path[:-1]:
        parent = click.Context(click.Group(name), info_name=name, parent=parent)
    context = click.Context(command, info_name=path[-1], parent=parent,
                            terminal_width=HELP_WIDTH, max_content_width=HELP_WIDTH)
    return command.get_help(context)


def cli_commands():
    """(path, command) of the top-level group and of every command under it, recursively."""
    from sarjax.cli.commands import cli

    found = [(("sarjax",), cli)]

    def walk(group, path):
        for name in sorted(group.commands):
            command = group.commands[name]
            found.append(((*path, name), command))
            if isinstance(command, click.Group):
                walk(command, (*path, name))

    walk(cli, ("sarjax",))
    return found


def cli_page() -> str:
    lines = []
    for path, command in cli_commands():
        title = " ".join(path)
        heading = "##" if len(path) == 2 else "###" if len(path) > 2 else None
        if heading:
            lines.append(f"{heading} `{title}`\n")
            summary = command.get_short_help_str(limit=HELP_WIDTH)
            if summary:
                lines.append(f"{summary}\n")
        else:
            lines.append("## `sarjax`\n")
        lines.append("```text")
        lines.append(f"$ {title} --help")
        lines.append(command_help(command, path))
        lines.append("```\n")
    return "\n".join(lines)


# --------------------------------------------------------------------------- TOML

COMMENTED_KEY = re.compile(r"^#\s*([A-Za-z_][A-Za-z0-9_]*)\s*=")
TABLE = re.compile(r"^\[([A-Za-z_][A-Za-z0-9_.]*)\]")


def example_keys(example: str) -> list[tuple[str, str, str, bool]]:
    """(section, key, comment, commented out) of every key of a TOML example, in order.

    The keys that are set are read with ``tomllib`` (so the example must parse); the
    optional ones shown commented out (``# key = value  # note``) are read from their line.
    """
    parsed = tomllib.loads(example)
    section = ""
    keys = []
    for line in example.splitlines():
        table = TABLE.match(line)
        if table:
            section = table.group(1)
            continue
        stripped = line.strip()
        commented = COMMENTED_KEY.match(stripped)
        if commented:
            key, body, is_commented = commented.group(1), stripped.lstrip("#").strip(), True
        elif stripped and not stripped.startswith("#") and "=" in stripped:
            key, body, is_commented = stripped.split("=", 1)[0].strip(), stripped, False
            where = parsed.get(section, {}) if section else parsed
            if key not in where:
                raise ValueError(f"TOML example: {key!r} not parsed under [{section}]")
        else:
            continue
        comment = body.split("#", 1)[1].strip() if "#" in body else ""
        keys.append((section, key, comment, is_commented))
    return keys


def config_page() -> str:
    from sarjax.cli.config import EXAMPLE

    rows = ["| section | key | default in the example | meaning |", "|---|---|---|---|"]
    for section, key, comment, commented in example_keys(EXAMPLE):
        where = f"`[{section}]`" if section else "(top level)"
        rows.append(f"| {where} | `{key}` | {'optional' if commented else 'set'} | "
                    f"{comment.replace('|', '&#124;')} |")
    return "\n".join(["```toml", EXAMPLE.rstrip("\n"), "```", "", *rows, ""])


# --------------------------------------------------------------------------- simulators


def yes(flag: bool) -> str:
    return "yes" if flag else "—"


def reported_budgets(cls) -> str:
    """The budgets ``sj.validity`` reports for the method (asked on a small scene: one
    target, and a 1 cm deviation where the method accepts motion), so the page lists what
    the code checks."""
    import warnings

    import numpy as np

    import sarjax as sj

    radar = sj.presets.airborne_xband(num_pulses=64, num_range=64)
    scene = sj.PointTargets(azimuth=[0.0], range=[float(radar.near_range) + 96.0])
    x = (np.arange(64) - 31.5) * float(radar.azimuth_spacing)
    motion = sj.Motion(horizontal=0.01 * np.sin(x / 9)) if cls.accepts_motion else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = sj.validity(radar, scene, motion, method=cls.names[0])
    return ", ".join(f"`{budget.name}`" for budget in report.budgets)


def simulators_page() -> str:
    from sarjax.simulators import _registry

    rows = [
        "| method (aliases) | class | implements | motion | squint | moving targets | "
        "exact | `auto` | budgets checked (`sj.validity`) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for cls in _registry.SIMULATORS:
        names = ", ".join(f"`{n}`" for n in cls.names)
        budgets = reported_budgets(cls)
        rows.append(
            f"| {names} | [`{cls.__name__}`][sarjax.simulators.{cls.__name__}] | "
            f"{cls.physics} | {cls.motion} | {yes(cls.supports_squint)} | "
            f"{yes(cls.supports_moving_targets)} | {yes(cls.exact)} | {yes(cls.in_auto)} | "
            f"{budgets} |")
    return "\n".join(rows) + "\n"


def thresholds_page() -> str:
    from sarjax.simulators import _budgets as b

    table = [
        ("`epsilon_motion`, `epsilon_11`, `epsilon_12`, `epsilon_13`", "PHASE_THRESHOLD",
         f"{b.PHASE_THRESHOLD:g} rad"),
        ("`epsilon_az`", "PATTERN_THRESHOLD", f"{b.PATTERN_THRESHOLD:g} (relative)"),
        ("`chirp_edges`", "CHIRP_EDGE_THRESHOLD",
         f"{b.CHIRP_EDGE_THRESHOLD:.3g} ({10 * _log10(b.CHIRP_EDGE_THRESHOLD):.0f} dB)"),
        ("`azimuth_aliases`", "AMBIGUITY_THRESHOLD",
         f"{b.AMBIGUITY_THRESHOLD:g} ({10 * _log10(b.AMBIGUITY_THRESHOLD):.0f} dB)"),
        ("`azimuth_extent`", "EXTENT_THRESHOLD", f"{b.EXTENT_THRESHOLD:g}"),
        ("`azimuth_sidelobes`", "SIDELOBE_THRESHOLD", f"{b.SIDELOBE_THRESHOLD:g}"),
        ("`azimuth_amplitude`, `azimuth_window`", "AMPLITUDE_THRESHOLD",
         f"{b.AMPLITUDE_THRESHOLD:.3g} ({10 * _log10(b.AMPLITUDE_THRESHOLD):.0f} dB)"),
        ("`range_window`", "ALL_MISSING", "1 (only a window that records nothing)"),
        ("`combined_error`, `recorded_phase_error`, `doppler_migration`", "COMBINED_THRESHOLD",
         f"{b.COMBINED_THRESHOLD:.3g}"),
    ]
    rows = ["| budget | constant in `sarjax.simulators._budgets` | threshold |",
            "|---|---|---|"]
    rows += [f"| {name} | `{const}` | {value} |" for name, const, value in table]
    return "\n".join(rows) + "\n"


def _log10(x: float) -> float:
    import math

    return math.log10(x)


PIECES = {
    "cli": cli_page,
    "config": config_page,
    "simulators": simulators_page,
    "thresholds": thresholds_page,
}


def on_page_markdown(markdown, page, config, files):
    def replace(match):
        name = match.group(1)
        if name not in PIECES:
            raise ValueError(f"{page.file.src_path}: unknown marker sarjax:{name}")
        return PIECES[name]()

    return MARKER.sub(replace, markdown)


# --------------------------------------------------------------------------- griffe

ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|attr|data|obj|exc|const):`(~?)([^`<>]+)`")


class SphinxRoles(griffe.Extension):
    """Sphinx roles (``:func:`~sarjax.simulate` ``) in docstrings become optional
    cross-references: a link where the target is documented on the site, the name in code
    font otherwise (never a warning)."""

    def on_instance(self, *, obj, **kwargs):
        docstring = obj.docstring
        if docstring is None or ":`" not in docstring.value:
            return

        module = obj.module.path if obj.module is not None else ""

        def replace(match):
            short, target = match.group(1), match.group(2).strip().removesuffix("()")
            title = target.rsplit(".", 1)[-1] if short else target
            if not target.startswith("sarjax"):
                target = f"{module}.{target}" if module else target
            return (f'<autoref identifier="{target}" optional>'
                    f"<code>{title}</code></autoref>")

        docstring.value = ROLE.sub(replace, docstring.value)
