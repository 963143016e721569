"""The `pyvehtrack` command: a package with one module per subcommand.

    pyvehtrack detect INPUT... [--out annotated.{png,mp4}] [--json OUT.json]
    pyvehtrack track INPUT... --out annotated.mp4 [--tracks tracks.txt]
    pyvehtrack eval --gt GT.txt --tracks tracks.txt
    pyvehtrack --version          python -m pyvehtrack ...  (the same command)

Adding a subcommand
-------------------
1. Write a module (here, e.g. `pyvehtrack/cli/classify.py`, or anywhere, e.g.
   `pyvehtrack/cli_classify.py`) with a function `register(subparsers)` that calls
   `subparsers.add_parser("name", help=..., epilog="examples: ...")`, adds its arguments and
   sets `func` with `p.set_defaults(func=run)`, where `run(args)` returns the exit code.
   Import heavy modules (cv2, the C core) inside `run`, not at module level: every
   subcommand's module is imported whenever the command line is parsed.
2. Add one line to SUBCOMMANDS below: `"name": "module"` (its `register`) or
   `"name": "module:function"` (another function name).
3. Report a user mistake by raising `CliError("what and which argument/file")`: main()
   prints it as one line `pyvehtrack NAME: error: ...` and exits with status 2. Use
   `common.frame_sources` / `common.FrameReader` to read frames (corrupt frames raise
   CliError or are skipped with --skip-bad-frames) and `common.Outputs` to write files all
   or nothing (check before the run, temporary files renamed into place at the end).

Modules import `pyvehtrack.cli.common`, never `pyvehtrack.cli` itself, so there is no
import loop (this file imports the subcommand modules only inside build_parser()).
"""
from __future__ import annotations

import argparse
import importlib
import sys

from .common import (IMAGE_EXTS, VIDEO_EXTS, VIDEO_OUT_EXTS, CliError, FrameReader, Outputs,  # noqa: F401
                     VideoOut, count_frames, frame_sources, read_image, video_fps)

__all__ = ["main", "build_parser", "SUBCOMMANDS", "CliError"]

# name -> "module" (its register function) or "module:function"; imported when the
# command line is parsed, in this order (the order of `pyvehtrack --help`).
SUBCOMMANDS: dict[str, str] = {
    "detect": "pyvehtrack.cli.detect",
    "track": "pyvehtrack.cli.track",
    "eval": "pyvehtrack.cli.eval",
    "calibrate": "pyvehtrack.cli.calibrate",
}

EXAMPLES = """examples:
  pyvehtrack detect frame.png --out annotated.png --json detections.json
  pyvehtrack track drive.mp4 --out annotated.mp4 --tracks tracks.txt
  pyvehtrack eval --gt gt.txt --tracks tracks.txt
  pyvehtrack COMMAND --help     (each command's options and examples)"""


# Names the single-file cli.py / cli_track.py had, kept for code written against them.
_frames_of, _count_frames, _video_fps = frame_sources, count_frames, video_fps


def _iter_frames(sources):
    """The old reader: (file, frame index within its file, frame); new code uses FrameReader."""
    last, k = None, 0
    for _i, path, img in FrameReader(sources):
        k = k + 1 if path == last else 0
        last = path
        yield path, k, img


_MOVED = {"draw_detection": ("detect", "draw_detection"), "detection_json": ("detect", "detection_json"),
          "register_detect": ("detect", "register"), "run_detect": ("detect", "run"),
          "draw_tracks": ("track", "draw_tracks"), "id_colour": ("track", "id_colour"),
          "kitti_line": ("track", "kitti_line"), "register_track": ("track", "register"),
          "run_track": ("track", "run"), "register_eval": ("eval", "register"), "run_eval": ("eval", "run")}


def __getattr__(name):
    """pyvehtrack.cli.draw_detection etc. (formerly in cli.py), loaded from their module on use."""
    if name in _MOVED:
        mod, attr = _MOVED[name]
        return getattr(importlib.import_module(f"{__name__}.{mod}"), attr)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit status 2): `pyvehtrack CMD: error: ...`."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__
    parser = _Parser(prog="pyvehtrack", description="Camera-based vehicle detection and tracking "
                     "(C fixed-point core, float reference).", epilog=EXAMPLES,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"pyvehtrack {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name, target in SUBCOMMANDS.items():
        mod_name, _, fn_name = target.partition(":")
        getattr(importlib.import_module(mod_name), fn_name or "register")(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line `argv` (default: sys.argv[1:]); returns the exit status:
    0 done, 2 a user error (one line on stderr), 130 interrupted."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:            # --help, --version (0) and usage errors (2)
        return int(e.code or 0) if not isinstance(e.code, str) else 2
    import warnings

    def one_line(message, category, *_args, **_kw):   # library warnings: one line, no source
        print(f"pyvehtrack {args.command}: warning: {message}", file=sys.stderr)

    try:
        with warnings.catch_warnings():
            warnings.showwarning = one_line
            return int(args.func(args) or 0)
    except CliError as e:
        print(f"pyvehtrack {args.command}: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:               # disk full, permission changed during the run, ...
        where = f"{e.filename}: " if e.filename else ""
        print(f"pyvehtrack {args.command}: error: {where}{e.strerror or e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"pyvehtrack {args.command}: interrupted", file=sys.stderr)
        return 130
