"""Regenerate the robot URDFs of sim/robots/ from sim/robots/robots.toml.

Usage: python sim/tools/make_urdf.py [--table sim/robots/robots.toml] [--out sim/robots]
The generator itself is kbplanner.robot.robot_model.write_urdfs; tests check the checked-in files match.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from kbplanner.robot.robot_model import write_urdfs

HERE = Path(__file__).resolve().parent


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", type=Path, default=HERE.parent / "robots" / "robots.toml")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: next to the table)")
    args = parser.parse_args(argv)
    for path in write_urdfs(args.table, args.out):
        sys.stdout.write(f"wrote {path}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
