"""Does a faster tail check still give the same answers? Record them, then compare.

The speed work on :func:`tail_check.detect` must not change what it answers. This
records every answer (verdict, score, box, ``ŝ``) on

* ``A``, ``B``: each generator's held-out seeds as arrays (``tail_check.dataset``);
* ``real``: every real photo (``DEPOT_REAL_DATA_DIR``; none shows a disc), as arrays;
* ``A.jpg``, ``B.jpg``: the same scenes as JPEG bytes (quality 92); ``real.jpg``: the
  photos' own files; ``A1080.jpg``: generator A at 1920x1080 (quality 90, the speed
  bench's images); ``B1080.jpg``: generator B's scenes enlarged to 1920x1080 (its own
  renderer takes seconds per scene at that size);

for the JPEG sets both through a full decode + ``detect`` (what the service did) and
through :func:`tail_check.detect_snapshot` (reduced decode). ``compare`` prints the
confusion per set and path, before and after, and every answer that changed; it exits
1 on a new false ``present`` or a lower correct count on any set.

Run: ``.venv/bin/python -m bench.tail_answers record FILE`` (before the change),
``.venv/bin/python -m bench.tail_answers compare FILE`` (after it).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np

import tail_check
from tail_check import decode_snapshot, detect
from tail_check.dataset import real_dir, real_photos, scenes
from tail_check.synth import iter_snapshots

cv2.setNumThreads(1)
COUNT = 150
"""Held-out scenes per generator (as ``bench.tail_accuracy``)."""
COUNT_1080 = 100
Item = tuple[str, bool, Any]
Answers = dict[str, dict[str, dict[str, Any]]]


def _jpeg(image: Any, quality: int) -> bytes:
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    assert ok
    return bytes(buf.tobytes())


def _arrays(name: str) -> Iterator[Item]:
    if name == "real":
        for s in real_photos("all"):
            yield f"{s.kind}/{s.name}", False, s.image
        return
    for s in scenes(name, "heldout", COUNT):  # type: ignore[arg-type]
        yield s.name, s.disc, s.image


def _jpegs(name: str) -> Iterator[Item]:
    if name == "real":
        for folder in sorted(p for p in real_dir().glob("*") if p.is_dir()):
            if folder.name in ("railsem19_frames", "red_wagons"):
                for path in sorted(folder.glob("*.jpg")):
                    yield f"{folder.name}/{path.name}", False, path.read_bytes()
    elif name == "A1080":
        for i, (image, label) in enumerate(iter_snapshots(91, COUNT_1080, size=(1920, 1080))):
            yield str(i), label.disc, _jpeg(image, 90)
    elif name == "B1080":
        for s in scenes("B", "heldout", COUNT_1080):
            big = cv2.resize(s.image, (1920, 1080), interpolation=cv2.INTER_LINEAR)
            yield s.name, s.disc, _jpeg(big, 90)
    else:
        for name_, disc, image in _arrays(name):
            yield name_, disc, _jpeg(image, 92)


def _answer(result: tail_check.DetectionResult, truth: bool) -> dict[str, Any]:
    return {"truth": truth, **result.to_dict()}


def collect(with_fast: bool, only: list[str] | None = None) -> Answers:
    """Every answer of the current code, keyed by ``set/path`` and item name."""
    out: Answers = {}
    runs: list[tuple[str, Callable[[str], Iterator[Item]], Callable[[Any], Any]]] = [
        ("A", _arrays, detect),
        ("B", _arrays, detect),
        ("real", _arrays, detect),
    ]
    for name in ("A", "B", "real", "A1080", "B1080"):
        runs.append((f"{name}.jpg", _jpegs, lambda data: detect(decode_snapshot(data))))
        if with_fast:
            runs.append((f"{name}.jpg fast", _jpegs, tail_check.detect_snapshot))
    for key, items, fn in runs:
        if only and not any(key.startswith(o) for o in only):
            continue
        source = key.split(".")[0]
        out[key] = {n: _answer(fn(x), truth) for n, truth, x in items(source)}
        print(f"  {key}: {len(out[key])} answers", flush=True)
    return out


def confusion(answers: dict[str, dict[str, Any]]) -> str:
    """``correct c/n, false present f, disc p/u/a, no-disc p/u/a``."""
    c: Counter[tuple[bool, str]] = Counter((a["truth"], a["verdict"]) for a in answers.values())
    correct = c[(True, "present")] + c[(False, "absent")]

    def row(truth: bool) -> str:
        return "/".join(str(c[(truth, v)]) for v in ("present", "uncertain", "absent"))

    return (
        f"correct {correct:3d}/{len(answers):3d}  false present {c[(False, 'present')]}  "
        f"disc p/u/a {row(True):>9s}  no-disc p/u/a {row(False):>9s}"
    )


def _correct(answers: dict[str, dict[str, Any]]) -> int:
    good = ("absent", "present")
    return sum(1 for a in answers.values() if a["verdict"] == good[int(a["truth"])])


def _false_present(answers: dict[str, dict[str, Any]]) -> set[str]:
    return {n for n, a in answers.items() if not a["truth"] and a["verdict"] == "present"}


def compare(before: Answers, after: Answers) -> int:
    """Print before/after per set and path; 1 when any set got worse."""
    worse = 0
    for key in after:
        # A fast path is judged against what the full decode answered before.
        old = before.get(key) or before[key.replace(" fast", "")]
        new = after[key]
        changed = [n for n in new if n in old and new[n]["verdict"] != old[n]["verdict"]]
        same = sum(1 for n in new if n in old and new[n] == old[n])
        print(f"{key:15s} before {confusion(old)}")
        print(f"{'':15s} after  {confusion(new)}   identical answers {same}/{len(new)}")
        for n in changed:
            print(
                f"{'':17s}{n}: {old[n]['verdict']} -> {new[n]['verdict']} (truth {new[n]['truth']})"
            )
        new_fp = _false_present(new) - _false_present(old)
        if new_fp or _correct(new) < _correct(old):
            print(f"{'':17s}WORSE: new false present {sorted(new_fp)}")
            worse = 1
    return worse


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("mode", choices=("record", "compare"))
    parser.add_argument("file", type=Path)
    parser.add_argument("--no-fast", action="store_true", help="skip detect_snapshot")
    parser.add_argument("--only", nargs="+", help="sets whose key starts so (e.g. A1080 real)")
    args = parser.parse_args(argv)
    os.environ.setdefault("DEPOT_TAIL_CACHE", "var/tail_cache")
    with_fast = not args.no_fast and hasattr(tail_check, "detect_snapshot")
    answers = collect(with_fast, args.only)
    if args.mode == "record":
        args.file.write_text(json.dumps(answers), encoding="utf-8")
        return 0
    return compare(json.loads(args.file.read_text(encoding="utf-8")), answers)


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
