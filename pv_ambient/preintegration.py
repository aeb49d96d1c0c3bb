"""``python -m pv_ambient.preintegration --build-default``: rebuild the preintegrated table that ships
with the package (``pv_ambient/data/default_table.npz``), reproducibly.

The tables themselves (estimator, table, disk store) are :mod:`pv_ambient.stages.preintegration`.
"""

from __future__ import annotations

import argparse

from .stages.preintegration import DEFAULT_TABLE_PATH, build_default


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pv_ambient.preintegration", description=__doc__.splitlines()[0])
    parser.add_argument("--build-default", action="store_true", help="rebuild pv_ambient/data/default_table.npz")
    parser.add_argument("--output", default=str(DEFAULT_TABLE_PATH), help="output path for --build-default")
    args = parser.parse_args(argv)
    if args.build_default:
        out = build_default(args.output)
        print(f"wrote {out} ({out.stat().st_size} bytes)")
        return 0
    parser.print_help()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
