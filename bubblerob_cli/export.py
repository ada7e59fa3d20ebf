"""``python -m policies.export_onnx``: export an SB3 model to ONNX (:mod:`policies.export_onnx`)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from bubblerob_cli.args import HelpFormatter
from bubblerob_cli.outputs import Output, OutputError, add_overwrite_option, check_outputs
from bubblerob_cli.stdout_guard import guarded
from bubblerob_env.extras import require_extra
from policies.export_onnx import SHIPPED_MODEL, export_onnx

__all__ = ["PROG", "build_parser", "main"]

PROG = "python -m policies.export_onnx"


def build_parser() -> argparse.ArgumentParser:
    """Command-line arguments of ``python -m policies.export_onnx``."""
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Export an SB3 model (+ its VecNormalize statistics) to ONNX for "
        "onnxruntime; by default the shipped PPO policy.",
        formatter_class=HelpFormatter,
    )
    parser.add_argument("model", type=Path, nargs="?", default=SHIPPED_MODEL, help="SB3 .zip")
    parser.add_argument("--out", type=Path, help="ONNX file (default: the model's path, .onnx)")
    add_overwrite_option(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m policies.export_onnx``."""
    parser = build_parser()
    args = parser.parse_args(argv)
    return guarded(PROG, lambda: _export(parser, args))


def _export(parser: argparse.ArgumentParser, args: argparse.Namespace) -> int:
    require_extra("train", PROG)
    if not args.model.is_file():
        parser.error(f"model {args.model} does not exist")
    out = args.out if args.out is not None else args.model.with_suffix(".onnx")
    try:
        check_outputs([Output("--out", out, (".onnx",))], args.overwrite, inputs=[args.model])
    except OutputError as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    try:
        out = export_onnx(args.model, out)
    except OSError as error:  # a full disk: one line
        print(f"{PROG}: cannot write --out {out}: {error.strerror or error}", file=sys.stderr)
        return 1
    print(f"wrote {out}")
    return 0
