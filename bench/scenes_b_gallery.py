"""Contact sheet of 24 generator-B scenes, for people to look at.

Usage: ``python bench/scenes_b_gallery.py OUT.png [FIRST_SEED]`` (without
arguments, as ``make bench`` runs it, it writes ``var/scenes_b_gallery.png``;
``var/`` is git-ignored). Each tile is
labelled with seed, condition and disc / negative kind; disc boxes are drawn
in green. The PNG is not meant to be committed.
"""

from __future__ import annotations

import sys
from pathlib import Path

# bench/tail_check.py is named like the package; keep this folder off the import path.
_HERE = Path(__file__).resolve().parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != _HERE]
sys.path.insert(0, str(_HERE.parent))

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import numpy.typing as npt  # noqa: E402

from tail_check.scenes_b import SceneB, render_scene  # noqa: E402

TILE = (480, 300)
COLUMNS = 4
COUNT = 24


def _tile(scene: SceneB, seed: int) -> npt.NDArray[np.uint8]:
    img = scene.image.copy()
    if scene.bbox is not None:
        x, y, w, h = scene.bbox
        pad = max(3, w // 3)
        cv2.rectangle(img, (x - pad, y - pad), (x + w + pad, y + h + pad), (0, 255, 0), 2)
    tile = np.asarray(cv2.resize(img, TILE, interpolation=cv2.INTER_AREA), dtype=np.uint8)
    what = "DISC" if scene.disc else f"no disc: {scene.negative_kind}"
    label = f"{seed} {scene.condition} {what} {scene.image.shape[1]}x{scene.image.shape[0]}"
    cv2.rectangle(tile, (0, 0), (TILE[0], 18), (0, 0, 0), -1)
    cv2.putText(tile, label, (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.42, (255, 255, 255), 1,
                cv2.LINE_AA)
    return tile


def main(argv: list[str]) -> int:
    out = Path(argv[1]) if len(argv) > 1 else _HERE.parent / "var" / "scenes_b_gallery.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    first = int(argv[2]) if len(argv) > 2 else 0
    tiles = [_tile(render_scene(s), s) for s in range(first, first + COUNT)]
    rows = [np.hstack(tiles[i : i + COLUMNS]) for i in range(0, COUNT, COLUMNS)]
    if not cv2.imwrite(str(out), np.vstack(rows)):
        print(f"could not write {out}; check the directory exists", file=sys.stderr)
        return 1
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv))
