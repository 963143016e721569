"""Run a pyvehtrack command or evaluation with tracker-config overrides (issue 8's
measurements of the template measurement, parts rule and width floor):

    VT_TRK='{"tmatch_radius": 4, "part_permille": 600}' \\
        python3 tools/with_tracker_cfg.py -m pyvehtrack.eval.kitti_track --data DIR
    VT_TRK='{"min_width": 4}' python3 tools/with_tracker_cfg.py -m pyvehtrack track VIDEO ...

$VT_TRK (JSON) fills the fields it names in every TrackerCfg (reference) and
TrackerConfig (library/CLI) built without them; the rest keep their defaults."""
import json
import os
import runpy
import sys

from pyvehtrack import config
from pyvehtrack.reference import tracker as rtrk

OVERRIDES = json.loads(os.environ.get("VT_TRK", "{}"))
for cls in (rtrk.TrackerCfg, config.TrackerConfig):
    def _init(self, *a, _orig=cls.__init__, **k):
        for key, v in OVERRIDES.items():
            k.setdefault(key, v)
        _orig(self, *a, **k)
    cls.__init__ = _init

if __name__ == "__main__":
    args = sys.argv[1:]
    if not args:
        sys.exit(__doc__)
    if args[0] == "-m":
        sys.argv = args[1:]
        runpy.run_module(args[1], run_name="__main__")
    else:
        sys.argv = args
        runpy.run_path(args[0], run_name="__main__")
