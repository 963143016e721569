#!/usr/bin/env python3
"""Read a callgrind output file: self and inclusive event counts per function.

Only the Python standard library; follows the callgrind format specification
(valgrind docs, "Callgrind Format Specification"):

- `events:` names the cost columns, `positions:` how many position columns lead
  each cost line (`line`, or `instr line` with --dump-instr=yes);
- `fn=` starts the costs of a function; a plain cost line adds to its self cost;
- `cfn=` names a callee, and the line after the next `calls=COUNT TARGET` holds
  the *inclusive* cost of those COUNT calls;
- names may be compressed: `(id) name` defines id, a later `(id)` refers to it
  (the fn= and cfn= lines share one table; so do fl/fi/fe/cfi/cfl, and ob/cob).

So for a function F that does not recurse:
  inclusive(F) = self(F) + sum of the call costs recorded under fn=F
and `calls_in(F)` (the calls recorded to F from anywhere) counts how often F ran.

    python bench/callgrind.py callgrind.out [FUNCTION...]
"""
from __future__ import annotations

import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

_COMPRESSED = re.compile(r"^\((\d+)\)(?:\s+(.*))?$")
_FN_KEYS = ("fn", "cfn")
_FILE_KEYS = ("fl", "fi", "fe", "cfi", "cfl")
_OBJ_KEYS = ("ob", "cob")


@dataclass
class Profile:
    """Per-function costs from one callgrind file, one list entry per event."""

    events: list[str] = field(default_factory=list)
    summary: list[int] = field(default_factory=list)
    self_cost: dict[str, list[int]] = field(default_factory=dict)
    call_cost: dict[str, list[int]] = field(default_factory=dict)  # costs of calls made by fn
    calls_in: dict[str, int] = field(default_factory=dict)  # times fn was called
    cost_in: dict[str, list[int]] = field(default_factory=dict)  # inclusive cost of those calls
    cmd: str = ""

    def _index(self, event: str) -> int:
        try:
            return self.events.index(event)
        except ValueError:
            raise KeyError(f"event {event!r} not in this profile (has {self.events})") from None

    def functions(self) -> list[str]:
        return sorted(set(self.self_cost) | set(self.calls_in))

    def self_of(self, fn: str, event: str = "Ir") -> int:
        i = self._index(event)
        return self.self_cost.get(fn, [0] * len(self.events))[i]

    def inclusive(self, fn: str, event: str = "Ir") -> int:
        """self(fn) + everything fn called. Raises KeyError for an unknown function."""
        if fn not in self.self_cost and fn not in self.calls_in:
            raise KeyError(f"function {fn!r} not in the profile")
        i = self._index(event)
        zero = [0] * len(self.events)
        return self.self_cost.get(fn, zero)[i] + self.call_cost.get(fn, zero)[i]

    def inclusive_from_callers(self, fn: str, event: str = "Ir") -> int:
        """The same figure from the other side: the sum of the inclusive costs
        recorded at every call site of fn (0 if no call to it was recorded)."""
        return self.cost_in.get(fn, [0] * len(self.events))[self._index(event)]

    def total(self, event: str = "Ir") -> int:
        return self.summary[self._index(event)] if self.summary else 0


def _add(table: dict[str, list[int]], key: str, costs: list[int], n: int) -> None:
    row = table.setdefault(key, [0] * n)
    for i, c in enumerate(costs[:n]):
        row[i] += c


def _name(value: str, table: dict[str, str]) -> str:
    m = _COMPRESSED.match(value.strip())
    if not m:
        return value.strip()
    ident, name = m.group(1), m.group(2)
    if name is not None:
        table[ident] = name.strip()
        return name.strip()
    try:
        return table[ident]
    except KeyError:
        raise ValueError(f"compressed name ({ident}) used before it was defined") from None


def _ints(tokens: list[str]) -> list[int]:
    return [int(t) for t in tokens]


def parse_text(text: str) -> Profile:
    prof = Profile()
    n_pos = 1
    names: dict[str, dict[str, str]] = {"fn": {}, "file": {}, "obj": {}}
    fn = None
    cfn = None
    pending_call: tuple[str, int] | None = None  # (callee, count) awaiting its cost line
    skip_next = False
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if pending_call is not None or skip_next:
            tokens = line.split()
            if pending_call is not None:
                callee, count = pending_call
                costs = _ints(tokens[n_pos:])
                n = len(prof.events)
                if fn is not None:
                    _add(prof.call_cost, fn, costs, n)
                _add(prof.cost_in, callee, costs, n)
                prof.calls_in[callee] = prof.calls_in.get(callee, 0) + count
            pending_call, skip_next = None, False
            continue
        head = line[0]
        if head.isdigit() or head in "+-*":
            if fn is None:
                raise ValueError(f"line {lineno}: cost line before any fn=")
            _add(prof.self_cost, fn, _ints(line.split()[n_pos:]), len(prof.events))
            continue
        key, sep, value = line.partition("=")
        if sep and key in _FN_KEYS:
            name = _name(value, names["fn"])
            if key == "fn":
                fn = name
                prof.self_cost.setdefault(fn, [0] * len(prof.events))
            else:
                cfn = name
            continue
        if sep and key in _FILE_KEYS:
            _name(value, names["file"])
            continue
        if sep and key in _OBJ_KEYS:
            _name(value, names["obj"])
            continue
        if sep and key == "calls":
            if cfn is None:
                raise ValueError(f"line {lineno}: calls= without a preceding cfn=")
            pending_call = (cfn, int(value.split()[0]))
            continue
        if sep and key in ("jump", "jcnd"):
            skip_next = True  # the following line is the jump's source position
            continue
        key, sep, value = line.partition(":")
        if sep:
            value = value.strip()
            if key == "events":
                prof.events = value.split()
            elif key == "positions":
                n_pos = len(value.split())
            elif key in ("summary", "totals"):
                if key == "summary" or not prof.summary:
                    prof.summary = _ints(value.split())
            elif key == "cmd":
                prof.cmd = value
            continue
        # Anything else (a future header) is ignored on purpose.
    if not prof.events:
        raise ValueError("not a callgrind file: no 'events:' line")
    return prof


def parse(path: str | Path) -> Profile:
    return parse_text(Path(path).read_text())


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__, file=sys.stderr)
        return 2
    prof = parse(argv[0])
    fns = argv[1:] or sorted(prof.functions(), key=lambda f: -prof.inclusive(f))[:30]
    print(f"{'inclusive Ir':>14} {'self Ir':>12} {'calls':>8}  function")
    for f in fns:
        print(f"{prof.inclusive(f):>14,} {prof.self_of(f):>12,} {prof.calls_in.get(f, 0):>8}  {f}")
    print(f"{prof.total():>14,} {'':>12} {'':>8}  (program total)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
