"""Command-line interface: a thin layer over the public API.

Exit codes: 0 success, 2 bad input (scene, archive or arguments), 1 any other
failure. Nothing is written unless the whole job succeeded.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ._version import __version__

EXIT_BAD_INPUT = 2


class _BadInput(Exception):
    pass


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="harmbal",
        description="Harmonic-domain balancing analysis of reciprocating machines.",
    )
    parser.add_argument("--version", action="version", version=f"harmbal {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = commands.add_parser(
        "run", help="analyse a scene and print the free forces and moments per order",
        description="Simulate the exact shaking loads of a scene, decompose them into orders and print "
                    "the free force and moment of each order (peak amplitude, phase, co/counter-rotating "
                    "split). With -o, also write the netCDF archive.")
    run.add_argument("scene", type=Path, help="scene file (TOML)")
    run.add_argument("-o", "--output", type=Path, help="write the analysis to this netCDF archive")
    run.add_argument("--backend", choices=("scipy", "numpy", "pyfftw"), default="scipy", help="FFT backend")
    run.set_defaults(handler=_run)

    show = commands.add_parser(
        "show", help="print the order table stored in an archive",
        description="Print the free forces and moments per order from a harmbal netCDF archive.")
    show.add_argument("archive", type=Path, help="netCDF archive written by 'harmbal run -o'")
    show.set_defaults(handler=_show)
    return parser


def _run(args) -> None:
    from .analysis import analyse
    from .archive import save
    from .scene import SceneError, load_scene
    from .tables import order_table

    if args.output is not None and not args.output.parent.is_dir():
        raise _BadInput(f"{args.output}: output directory {args.output.parent} does not exist")
    try:
        scene = load_scene(args.scene)
    except SceneError as exc:
        raise _BadInput(str(exc)) from None
    except OSError as exc:
        raise _BadInput(f"{args.scene}: cannot read scene ({exc.strerror or exc})") from None
    tree = analyse(scene, backend=args.backend)
    print(order_table(tree["orders"].ds))
    if args.output is not None:
        save(tree, args.output)
        print(f"\nwrote {args.output}")


def _show(args) -> None:
    from .archive import ArchiveError, open_archive
    from .tables import order_table

    try:
        tree = open_archive(args.archive)
    except FileNotFoundError:
        raise _BadInput(f"{args.archive}: no such file") from None
    except ArchiveError as exc:
        raise _BadInput(str(exc)) from None
    if "orders" not in tree.children:
        raise _BadInput(f"{args.archive}: archive has no /orders group")
    print(order_table(tree["orders"].ds))


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``harmbal`` command; returns the exit code."""
    args = _parser().parse_args(argv)
    try:
        args.handler(args)
    except _BadInput as exc:
        for line in str(exc).splitlines():
            print(f"harmbal: error: {line}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return 0


if __name__ == "__main__":
    sys.exit(main())
